// `cairn eval` end to end: 3D TUM files and graphs, pairing by nearest stamp
// within --max-dt, the alignments, and FILE:LINE errors for bad lines.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "test_util.h"

namespace cairn {
namespace {

using testing::JsonNumber;
using testing::RunCommand;
using testing::TempDir;

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A TUM file of a climbing, tilting path; z_noise adds a random z error of
// up to that many metres to each pose, scale and dt move the copy.
std::string WriteTum(const std::string& name, double z_noise = 0, double dt = 0, double scale = 1) {
  const std::string path = TempDir() + "/" + name;
  std::ofstream out(path);
  out.precision(17);
  out << "# timestamp tx ty tz qx qy qz qw\n";
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> dz(-z_noise, z_noise);
  for (int i = 0; i < 150; ++i) {
    const double a = 0.04 * i, tilt = 0.1 * std::sin(a);
    const double z = 0.03 * i + (z_noise > 0 ? dz(rng) : 0);
    // Yaw a, then a roll of `tilt`: q = (cos(a/2) + k sin(a/2)) (cos(t/2) + i sin(t/2)).
    const double cy = std::cos(a / 2), sy = std::sin(a / 2), cr = std::cos(tilt / 2), sr = std::sin(tilt / 2);
    out << 50 + 0.1 * i + dt << ' ' << scale * 4 * std::cos(a) << ' ' << scale * 4 * std::sin(a) << ' '
        << scale * z << ' ' << cy * sr << ' ' << sy * sr << ' ' << sy * cr << ' ' << cy * cr << '\n';
  }
  return path;
}

struct EvalRun {
  int status = -1;
  std::string out, err, json;
};

EvalRun Eval(const std::string& args) {
  static int n = 0;
  const std::string stem = TempDir() + "/eval" + std::to_string(n++);
  EvalRun r;
  r.out = RunCommand(std::string(CAIRN_TOOL) + " eval " + args + " --json " + stem + ".json 2> " + stem + ".err",
                     &r.status);
  r.err = Slurp(stem + ".err");
  r.json = Slurp(stem + ".json");
  return r;
}

TEST(EvalTool, ZOffByUpToTwoMetresGivesAnAteAboveOneMetre) {
  const std::string ref = WriteTum("ref.tum"), est = WriteTum("z_off.tum", 2.0);
  const EvalRun r = Eval(est + " " + ref);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_GT(JsonNumber(r.json, "ate_rmse"), 1.0) << r.json;
  EXPECT_EQ(JsonNumber(r.json, "dimension"), 3) << r.json;
  EXPECT_EQ(JsonNumber(r.json, "matched"), 150) << r.json;
  EXPECT_NE(r.out.find("evaluated in 3D"), std::string::npos) << r.out;
  // Against itself: nothing.
  const EvalRun same = Eval(ref + " " + ref);
  ASSERT_EQ(same.status, 0) << same.err;
  EXPECT_LT(JsonNumber(same.json, "ate_rmse"), 1e-9);
}

TEST(EvalTool, StampsFourMillisecondsApartPairUnlessMaxDtIsTighter) {
  const std::string ref = WriteTum("ref4.tum"), est = WriteTum("late.tum", 0, 0.004);
  const EvalRun r = Eval(est + " " + ref);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(JsonNumber(r.json, "matched"), 150) << r.json;
  EXPECT_EQ(JsonNumber(r.json, "unpaired_ref"), 0) << r.json;
  EXPECT_LT(JsonNumber(r.json, "ate_rmse"), 1e-9) << r.json;
  const EvalRun tight = Eval(est + " " + ref + " --max-dt 0.001");
  EXPECT_NE(tight.status, 0);
  EXPECT_EQ(tight.err.rfind("cairn: ", 0), 0u) << tight.err;
  EXPECT_NE(tight.err.find("only 0 poses"), std::string::npos) << tight.err;
  EXPECT_TRUE(tight.json.empty());
}

TEST(EvalTool, Sim3ReportsTheScale) {
  const std::string ref = WriteTum("ref_s.tum"), est = WriteTum("half.tum", 0, 0, 0.5);
  const EvalRun sim3 = Eval(est + " " + ref + " --align sim3");
  ASSERT_EQ(sim3.status, 0) << sim3.err;
  EXPECT_NEAR(JsonNumber(sim3.json, "scale"), 2.0, 1e-9) << sim3.json;
  EXPECT_LT(JsonNumber(sim3.json, "ate_rmse"), 1e-9) << sim3.json;
  const EvalRun se3 = Eval(est + " " + ref);
  ASSERT_EQ(se3.status, 0) << se3.err;
  EXPECT_GT(JsonNumber(se3.json, "ate_rmse"), 0.5) << se3.json;
  EXPECT_EQ(JsonNumber(se3.json, "scale"), 1) << se3.json;
  const EvalRun bad = Eval(est + " " + ref + " --align affine");
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("--align"), std::string::npos) << bad.err;
}

TEST(EvalTool, MalformedLineIsAnErrorWithFileAndLine) {
  std::string text = Slurp(WriteTum("good.tum"));
  text += "66.0 1 2 3 0 0 0\n";  // a field short, at the end
  const std::string bad = TempDir() + "/bad.tum";
  std::ofstream(bad) << text;
  size_t lines = 0;
  for (char c : text) lines += c == '\n';
  const EvalRun r = Eval(bad + " " + WriteTum("ref_b.tum"));
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("cairn: " + bad + ":" + std::to_string(lines) + ": ", 0), 0u) << r.err;
  EXPECT_TRUE(r.json.empty());
}

// 3D graphs, which eval refused before, pair by vertex id; a planar
// trajectory against one is lifted to z = 0 and says so.
TEST(EvalTool, ThreeDimensionalGraphs) {
  const std::string g = TempDir() + "/sphere.g2o";
  int status = -1;
  RunCommand(std::string(CAIRN_TOOL) + " simulate --dim 3 --poses 200 --seed 3 -o " + g + " 2>&1", &status);
  ASSERT_EQ(status, 0);
  const std::string truth = TempDir() + "/sphere_truth.g2o";
  ASSERT_TRUE(std::filesystem::exists(truth));
  const EvalRun r = Eval(g + " " + truth);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(JsonNumber(r.json, "dimension"), 3) << r.json;
  EXPECT_EQ(JsonNumber(r.json, "matched"), 200) << r.json;
  EXPECT_GT(JsonNumber(r.json, "ate_rmse"), 0) << r.json;
  EXPECT_GT(JsonNumber(r.json, "rpe_rot_rmse_deg"), 0) << r.json;

  const std::string flat = TempDir() + "/flat.g2o";
  std::ofstream(flat) << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n";
  const EvalRun mixed = Eval(flat + " " + truth);
  ASSERT_EQ(mixed.status, 0) << mixed.err;
  EXPECT_EQ(JsonNumber(mixed.json, "dimension"), 3) << mixed.json;
  EXPECT_EQ(JsonNumber(mixed.json, "est_dimension"), 2) << mixed.json;
  EXPECT_NE(mixed.out.find(flat + " is planar"), std::string::npos) << mixed.out;
}

}  // namespace
}  // namespace cairn
