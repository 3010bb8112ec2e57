// What `cairn` prints on stderr: glog's lines (Ceres's and cairn's) only
// with --verbose, and every error starting with "cairn:" and naming the
// file and line when there is one; unknown tags refused or carried through.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "test_util.h"

namespace cairn {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::path(testing::TempDir()) / name;
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs the tool with `args`; returns its stderr alone.
std::string Stderr(const std::string& args, int* status) {
  return testing::RunCommand(std::string(CAIRN_TOOL) + " " + args + " 2>&1 >/dev/null", status);
}

// glog's prefix: severity, date, time, thread, file:line].
bool HasGlogLine(const std::string& text) {
  return std::regex_search(text, std::regex("(^|\n)[IWEF][0-9]{8} [0-9:.]+ +[0-9]+ [^ ]+:[0-9]+\\]"));
}

// Every line starts with "cairn:".
void ExpectCairnLines(const std::string& text) {
  EXPECT_FALSE(text.empty());
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    EXPECT_EQ(line.rfind("cairn: ", 0), 0u) << "a line of stderr: " << line;
}

const char* kGraph =
    "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.1 0 0\nEDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\n";

TEST(ToolStderr, AFailingSolvePrintsNoGlogLineWithoutVerbose) {
  const std::string in = WriteTemp("g.g2o", kGraph);
  const std::string out = testing::TempDir() + "/out.g2o";
  // Ceres refuses a damping bound above its own maximum (which cairn does not
  // check) with a glog line of its own before failing.
  int status = 0;
  const std::string quiet =
      Stderr("optimize " + in + " -o " + out + " --quiet --min-lm-diagonal 1e40", &status);
  EXPECT_NE(status, 0);
  EXPECT_FALSE(HasGlogLine(quiet)) << quiet;
  ExpectCairnLines(quiet);
  EXPECT_NE(quiet.find("min_lm_diagonal"), std::string::npos) << quiet;
  const std::string verbose =
      Stderr("optimize " + in + " -o " + out + " --quiet --min-lm-diagonal 1e40 --verbose", &status);
  EXPECT_NE(status, 0);
  EXPECT_TRUE(HasGlogLine(verbose)) << verbose;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(ToolStderr, ErrorsStartWithCairnAndNameFileAndLine) {
  int status = 0;
  const std::string spin = WriteTemp("spin.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 1e17\n");
  std::string err = Stderr("info " + spin, &status);
  EXPECT_EQ(status, 1);
  ExpectCairnLines(err);
  EXPECT_EQ(err.rfind("cairn: " + spin + ":2: theta 1e+17 rad is out of range", 0), 0u) << err;

  const std::string log = WriteTemp("far.log", "ODOM 1e300 0 0 0 0 0 1 h 1\n");
  err = Stderr("map " + log + " -o " + testing::TempDir() + "/m", &status);
  EXPECT_NE(status, 0);
  ExpectCairnLines(err);
  EXPECT_EQ(err.rfind("cairn: " + log + ":1: ", 0), 0u) << err;

  err = Stderr("compare " + WriteTemp("c.g2o", kGraph) + " --repeat 0", &status);
  EXPECT_NE(status, 0);
  EXPECT_EQ(err.rfind("cairn: ", 0), 0u) << err;
}

TEST(ToolStderr, VerboseIsAcceptedByEveryCommand) {
  const std::string in = WriteTemp("v.g2o", kGraph);
  int status = 0;
  testing::RunCommand(std::string(CAIRN_TOOL) + " info --verbose " + in + " >/dev/null 2>&1", &status);
  EXPECT_EQ(status, 0);
  const std::string help = testing::RunCommand(std::string(CAIRN_TOOL) + " eval --help", &status);
  EXPECT_NE(help.find("--verbose"), std::string::npos) << help;
  EXPECT_NE(help.find("--keep-unknown"), std::string::npos) << help;
}

TEST(ToolStderr, UnknownTagsAreRefusedOrCarriedThrough) {
  const std::string text =
      "VERTEX_SE2 0 0 0 0\nVERTEX_LINE2D 7 1 2\nVERTEX_SE2 1 1 0 0\n"
      "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\nEDGE_SE2_LINE2D 0 7 1 2 1 0 1\n";
  const std::string in = WriteTemp("u.g2o", text);
  const std::string out = testing::TempDir() + "/u_out.g2o";
  int status = 0;
  std::string err = Stderr("optimize " + in + " -o " + out + " --quiet", &status);
  EXPECT_EQ(status, 1);
  EXPECT_EQ(err.rfind("cairn: " + in + ":2: unknown tag 'VERTEX_LINE2D'", 0), 0u) << err;
  // --strict is still accepted, and still refuses.
  err = Stderr("info --strict " + in, &status);
  EXPECT_EQ(status, 1);
  err = Stderr("optimize " + in + " -o " + out + " --quiet --keep-unknown", &status);
  EXPECT_EQ(status, 0) << err;
  EXPECT_EQ(ReadAll(out), text);
}

}  // namespace
}  // namespace cairn
