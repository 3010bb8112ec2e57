// `cairn optimize` and `cairn compare` start from --init auto by default:
// the decision on stdout and in the JSON, the good minimum on a graph whose
// file start leads to a bad one, and --init file as before.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "test_util.h"

namespace {

std::string Tool() { return CAIRN_TOOL; }

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// 3,000 poses with strong heading noise (seed 1): from the file's
// odometry-chained vertices both solvers end metres off.
std::string HeadingNoiseGraph() {
  const std::string path = cairn::testing::TempDir() + "/cairn_heading.g2o";
  int status = -1;
  const std::string log = cairn::testing::RunCommand(
      Tool() + " simulate --poses 3000 --rotation-noise 0.1 --seed 1 -o '" + path + "' 2>&1",
      &status);
  EXPECT_EQ(status, 0) << log;
  return path;
}

double Ate(const std::string& estimate, const std::string& truth) {
  int status = -1;
  const std::string out = cairn::testing::RunCommand(
      Tool() + " eval '" + estimate + "' '" + truth + "' --json '" + estimate + ".json'", &status);
  EXPECT_EQ(status, 0) << out;
  return cairn::testing::JsonNumber(ReadText(estimate + ".json"), "ate_rmse");
}

TEST(OptimizeInit, AutoIsTheDefaultAndReachesTheGoodMinimum) {
  const std::string in = HeadingNoiseGraph();
  const std::string truth = cairn::testing::TempDir() + "/cairn_heading_truth.g2o";
  for (const std::string solver : {"gn", "ceres"}) {
    SCOPED_TRACE(solver);
    const std::string out = cairn::testing::TempDir() + "/cairn_auto_" + solver + ".g2o";
    const std::string report = out + ".report.json";
    int status = -1;
    const std::string stdout_text = cairn::testing::RunCommand(
        Tool() + " optimize '" + in + "' -o '" + out + "' --solver " + solver + " --report '" +
            report + "' 2>/dev/null",
        &status);
    ASSERT_EQ(status, 0) << stdout_text;
    EXPECT_NE(stdout_text.find("initial estimate (auto): chordal"), std::string::npos)
        << stdout_text;
    const std::string json = ReadText(report);
    EXPECT_NE(json.find("\"init\": \"auto\""), std::string::npos) << json;
    EXPECT_NE(json.find("\"init_chosen\": \"chordal\""), std::string::npos) << json;
    const double file_chi2 = cairn::testing::JsonNumber(json, "init_file_chi2");
    const double chordal_chi2 = cairn::testing::JsonNumber(json, "init_chordal_chi2");
    EXPECT_LT(chordal_chi2, file_chi2);
    // The context's figures have 10 digits.
    EXPECT_NEAR(cairn::testing::JsonNumber(json, "initial_chi2"), chordal_chi2, 1e-9 * chordal_chi2);
    EXPECT_NE(json.find("\"converged\": true"), std::string::npos) << json;
    EXPECT_LT(Ate(out, truth), 1.0);

    const std::string file_out = cairn::testing::TempDir() + "/cairn_file_" + solver + ".g2o";
    const std::string file_report = file_out + ".report.json";
    const std::string file_stdout = cairn::testing::RunCommand(
        Tool() + " optimize '" + in + "' -o '" + file_out + "' --solver " + solver +
            " --init file --report '" + file_report + "' 2>/dev/null",
        &status);
    ASSERT_EQ(status, 0) << file_stdout;
    EXPECT_EQ(file_stdout.find("initial estimate"), std::string::npos) << file_stdout;
    const std::string file_json = ReadText(file_report);
    EXPECT_NE(file_json.find("\"init\": \"file\""), std::string::npos);
    EXPECT_EQ(file_json.find("init_chosen"), std::string::npos);
    EXPECT_NEAR(cairn::testing::JsonNumber(file_json, "initial_chi2"), file_chi2, 1e-9 * file_chi2);
    EXPECT_GT(Ate(file_out, truth), 3.0);
  }
}

TEST(CompareInit, AutoIsTheDefaultAndReported) {
  const std::string path = cairn::testing::TempDir() + "/cairn_compare_auto.g2o";
  int status = -1;
  cairn::testing::RunCommand(Tool() + " simulate --poses 300 -o '" + path + "' 2>&1", &status);
  ASSERT_EQ(status, 0);
  const std::string json = path + ".json";
  const std::string out = cairn::testing::RunCommand(
      Tool() + " compare --quiet --json '" + json + "' '" + path + "' 2>/dev/null", &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("initial estimate (auto): "), std::string::npos) << out;
  const std::string text = ReadText(json);
  EXPECT_NE(text.find("\"method\": \"auto\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"chosen\": "), std::string::npos) << text;
  const double file_chi2 = cairn::testing::JsonNumber(text, "file_chi2");
  const double chordal_chi2 = cairn::testing::JsonNumber(text, "chordal_chi2");
  EXPECT_DOUBLE_EQ(cairn::testing::JsonNumber(text, "chi2"), std::min(file_chi2, chordal_chi2));
}

TEST(OptimizeInit, UnknownInitIsRefused) {
  int status = -1;
  const std::string out = cairn::testing::RunCommand(
      Tool() + " optimize x.g2o -o y.g2o --init best 2>&1", &status);
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("auto"), std::string::npos) << out;
}

}  // namespace
