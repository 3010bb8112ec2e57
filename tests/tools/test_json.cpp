// Every JSON cairn writes parses, whatever the input's name holds (quotes,
// backslashes, newlines), and numbers JSON cannot hold come out as null with
// a note.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cairn/solvers/solve_result.h"
#include "test_util.h"

namespace cairn {
namespace {

using json = nlohmann::ordered_json;  // keeps the order the keys were written in

// `text` as one word for sh: in single quotes, each ' closed, escaped, reopened.
std::string Quoted(const std::string& text) {
  std::string q = "'";
  for (char c : text) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string Tool() { return CAIRN_TOOL; }

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Parses or fails the test with the text that did not parse.
json Parsed(const std::string& text, const std::string& what) {
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    ADD_FAILURE() << what << " is not JSON (" << e.what() << "):\n" << text;
    return json();
  }
}

// Runs `args` (already quoted) and expects exit status 0.
std::string Cairn(const std::string& args) {
  int status = -1;
  const std::string out = testing::RunCommand(Tool() + " " + args + " 2>/dev/null", &status);
  EXPECT_EQ(status, 0) << args << "\n" << out;
  return out;
}

class WeirdName : public ::testing::TestWithParam<std::string> {};

TEST_P(WeirdName, EveryJsonWritingCommandParses) {
  const std::string dir = testing::TempDir() + "/json_" + std::to_string(
      std::hash<std::string>()(GetParam()));
  std::filesystem::create_directories(dir);
  const std::string in = dir + "/" + GetParam() + ".g2o";
  const std::string truth = dir + "/truth.g2o", opt = dir + "/opt.g2o";
  Cairn("simulate --dim 2 --poses 120 --seed 3 -o " + Quoted(in) + " --truth " + Quoted(truth));

  const json info = Parsed(Cairn("info --json " + Quoted(in)), "info --json");
  EXPECT_EQ(info.value("file", ""), in);
  EXPECT_EQ(info.value("vertices", 0), 120);

  const std::string report = dir + "/report.json";
  Cairn("optimize --quiet " + Quoted(in) + " -o " + Quoted(opt) + " --covariance 3,7 --report " +
      Quoted(report));
  const json r = Parsed(Slurp(report), "optimize --report");
  EXPECT_EQ(r.value("input", ""), in);
  EXPECT_EQ(r.value("output", ""), opt);
  EXPECT_TRUE(r.contains("trace") && r["trace"].is_array());
  EXPECT_EQ(r["covariance"]["3"].size(), 3u);

  const std::string rejecting = dir + "/rejecting.json";
  Cairn("optimize --quiet --solver gn --reject-outliers " + Quoted(in) + " -o " +
      Quoted(dir + "/opt_gn.g2o") + " --report " + Quoted(rejecting));
  const json rr = Parsed(Slurp(rejecting), "optimize --reject-outliers --report");
  EXPECT_TRUE(rr.begin().key() == "rejected_loop_closures" && rr.begin()->is_array());
  EXPECT_EQ(rr.value("solver", ""), "gn");

  const std::string compare = dir + "/compare.json";
  Cairn("compare --quiet " + Quoted(in) + " --json " + Quoted(compare));
  const json c = Parsed(Slurp(compare), "compare --json");
  EXPECT_EQ(c.value("file", ""), in);
  EXPECT_TRUE(c["ceres"].is_object() && c["gn"].is_object());

  const std::string eval = dir + "/eval.json";
  Cairn("eval " + Quoted(in) + " " + Quoted(truth) + " --json " + Quoted(eval));
  EXPECT_TRUE(Parsed(Slurp(eval), "eval --json").contains("ate_rmse"));

  const std::string calibrate = dir + "/calibrate.json";
  Cairn("calibrate --quiet --g2o " + Quoted(opt) + " --odometry " + Quoted(in) + " --json " +
      Quoted(calibrate));
  const json cal = Parsed(Slurp(calibrate), "calibrate --json");
  EXPECT_EQ(cal.value("input", ""), opt + " + " + in);
  EXPECT_EQ(cal["X"].size(), 3u);
}

INSTANTIATE_TEST_SUITE_P(Names, WeirdName,
                         ::testing::Values(std::string("we\"ird"), std::string("back\\slash"),
                                           std::string("new\nline"), std::string("all \"\\\n\t' of them")),
                         [](const auto& info) { return "name" + std::to_string(info.index); });

// A chi-squared that overflows: info --json writes null and says why.
TEST(JsonNonFinite, InfoWritesNullWithANote) {
  const std::string path = testing::TempDir() + "/huge.g2o";
  {
    std::ofstream out(path);
    out << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1e5 0 0\n"
           "EDGE_SE2 0 1 1 0 0 1e300 0 0 1e300 0 1e300\n";
  }
  const json info = Parsed(Cairn("info --json " + Quoted(path)), "info --json");
  ASSERT_TRUE(info.contains("chi2"));
  EXPECT_TRUE(info["chi2"].is_null());
  EXPECT_EQ(info.value("chi2_note", ""), "not finite (inf)");
}

TEST(JsonNonFinite, ReportWritesNullWithANote) {
  SolveResult r;
  r.solver = "ceres";
  r.initial_chi2 = std::numeric_limits<double>::quiet_NaN();
  r.final_chi2 = -std::numeric_limits<double>::infinity();
  IterationRecord it;
  it.chi2 = std::numeric_limits<double>::infinity();
  r.trace.push_back(it);
  std::ostringstream os;
  WriteReportJson(r, os, {{"input", "a \"quoted\"\\ name\n"}, {"vertices", "6"}});
  const json j = Parsed(os.str(), "WriteReportJson");
  EXPECT_EQ(j.value("input", ""), "a \"quoted\"\\ name\n");
  EXPECT_EQ(j.value("vertices", 0), 6);
  EXPECT_TRUE(j["initial_chi2"].is_null());
  EXPECT_EQ(j.value("initial_chi2_note", ""), "not finite (nan)");
  EXPECT_EQ(j.value("final_chi2_note", ""), "not finite (-inf)");
  EXPECT_TRUE(j["trace"][0]["chi2"].is_null());
  EXPECT_EQ(j["trace"][0].value("chi2_note", ""), "not finite (inf)");
  EXPECT_FALSE(j.contains("time_s_note"));
}

}  // namespace
}  // namespace cairn
