// Odometry calibration (u* = X u): recovery of a known X within the reported
// uncertainty, the identity case, refused degenerate inputs, the three
// methods' agreement, the input formats, the tool, and the intel log.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "cairn/graph/graph_io.h"
#include "cairn/graph/output_files.h"
#include "cairn/calibration/odometry_calibration.h"
#include "cairn/frontend/calibration_log.h"
#include "test_util.h"

namespace cairn {
namespace {

using testing::DatasetPath;
using testing::JsonNumber;
using testing::RunCommand;

Eigen::Matrix3d TrueX() {
  Eigen::Matrix3d x;
  x << 1.04, 0.01, 0.02, -0.015, 0.96, 0.05, 0.003, -0.02, 0.93;
  return x;
}

// A robot that drives forward, drifts a little sideways and turns.
Eigen::Vector3d RandomIncrement(std::mt19937& rng) {
  std::uniform_real_distribution<double> forward(0.05, 0.5);
  std::normal_distribution<double> side(0, 0.05), turn(0, 0.3);
  return {forward(rng), side(rng), turn(rng)};
}

CalibrationData Synthetic(const Eigen::Matrix3d& x, int n, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> e(0, 1);
  CalibrationData data;
  for (int i = 0; i < n; ++i) {
    CalibrationPair p;
    p.u = RandomIncrement(rng);
    p.u_star = x * p.u + noise * Eigen::Vector3d(e(rng), e(rng), e(rng));
    data.pairs.push_back(p);
  }
  return data;
}

std::string TempPath(const std::string& name) {
  const auto dir = std::filesystem::path(cairn::testing::TempDir()) /
                   ("cairn_calib_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

void ExpectWithinSigma(const CalibrationResult& r, const Eigen::Matrix3d& truth, double k) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      EXPECT_GT(r.x_std(i, j), 0);
      EXPECT_LT(std::abs(r.x(i, j) - truth(i, j)), k * r.x_std(i, j)) << "X(" << i << "," << j << ")";
    }
}

TEST(Calibration, RecoversKnownXWithinReportedUncertainty) {
  const double noise = 0.01;
  const CalibrationResult r = Calibrate(Synthetic(TrueX(), 500, noise, 1));
  ExpectWithinSigma(r, TrueX(), 4);
  // The fitted noise level is the simulated one.
  EXPECT_NEAR(std::sqrt(r.sigma2), noise, 0.1 * noise);
  EXPECT_FALSE(r.covariance_from_information);
  EXPECT_LT(r.rms_after, r.rms_before);
  EXPECT_NEAR(r.rms_after, noise, 0.1 * noise);
}

TEST(Calibration, ReportedUncertaintyMatchesTheScatter) {
  // Over many draws the error of X(0,0) divided by its reported std has unit spread.
  double sum2 = 0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const CalibrationResult r = Calibrate(Synthetic(TrueX(), 60, 0.02, 100 + t));
    const double z = (r.x(0, 0) - TrueX()(0, 0)) / r.x_std(0, 0);
    sum2 += z * z;
  }
  EXPECT_NEAR(std::sqrt(sum2 / trials), 1.0, 0.15);
}

TEST(Calibration, WithInformationUsesHInverse) {
  std::mt19937 rng(4);
  std::normal_distribution<double> e(0, 1);
  Eigen::Matrix3d cov;
  cov << 4e-4, 1e-4, 0, 1e-4, 2e-4, 0, 0, 0, 1e-4;
  const Eigen::Matrix3d l = cov.llt().matrixL();
  CalibrationData data;
  data.has_information = true;
  for (int i = 0; i < 400; ++i) {
    CalibrationPair p;
    p.u = RandomIncrement(rng);
    p.u_star = TrueX() * p.u + l * Eigen::Vector3d(e(rng), e(rng), e(rng));
    p.information = cov.inverse();
    data.pairs.push_back(p);
  }
  const CalibrationResult r = Calibrate(data);
  EXPECT_TRUE(r.covariance_from_information);
  ExpectWithinSigma(r, TrueX(), 4);
  EXPECT_LT(r.max_disagreement, 1e-9);
  // Whitened: chi2 per degree of freedom near one.
  EXPECT_NEAR(r.chi2_after / (3 * 400 - 9), 1.0, 0.15);
}

TEST(Calibration, ThreeMethodsAgree) {
  for (unsigned seed : {2u, 3u, 5u}) {
    const CalibrationResult r = Calibrate(Synthetic(TrueX(), 100, 0.05, seed));
    ASSERT_TRUE(r.has_gauss_newton && r.has_ceres);
    EXPECT_EQ(r.gauss_newton_iterations, 1);
    EXPECT_LT((r.x_gauss_newton - r.x_closed_form).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((r.x_ceres - r.x_closed_form).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT(r.max_disagreement, 1e-9);
  }
}

TEST(Calibration, PerfectOdometryGivesIdentity) {
  const CalibrationData data = Synthetic(Eigen::Matrix3d::Identity(), 50, 0, 7);
  const CalibrationResult r = Calibrate(data);
  EXPECT_LT((r.x - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((r.x_gauss_newton - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((r.x_ceres - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(r.rms_before, 0);
  EXPECT_LT(r.rms_after, 1e-12);
}

std::string RefusalOf(const CalibrationData& data) {
  try {
    Calibrate(data);
  } catch (const DegenerateCalibration& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Calibration, RefusesTooFewPairs) {
  const std::string why = RefusalOf(Synthetic(TrueX(), 2, 0.01, 1));
  EXPECT_NE(why.find("at least 3 pairs"), std::string::npos) << why;
  EXPECT_NE(RefusalOf(CalibrationData{}).find("got 0"), std::string::npos);
  // Three suffice for X itself; its spread then has no degrees of freedom.
  const CalibrationResult r = Calibrate(Synthetic(TrueX(), 3, 0.01, 1));
  EXPECT_TRUE(std::isnan(r.x_std(0, 0)));
}

TEST(Calibration, RefusesUnexcitedDirections) {
  CalibrationData straight = Synthetic(TrueX(), 100, 0, 1);
  for (CalibrationPair& p : straight.pairs) p.u[2] = 0;
  std::string why = RefusalOf(straight);
  EXPECT_NE(why.find("never turned"), std::string::npos) << why;
  EXPECT_NE(why.find("theta column"), std::string::npos) << why;

  // Straight lines only: both columns named.
  CalibrationData line = straight;
  for (CalibrationPair& p : line.pairs) p.u[1] = 0;
  why = RefusalOf(line);
  EXPECT_NE(why.find("theta column"), std::string::npos) << why;
  EXPECT_NE(why.find("y column"), std::string::npos) << why;

  CalibrationData no_side = Synthetic(TrueX(), 100, 0, 1);
  for (CalibrationPair& p : no_side.pairs) p.u[1] = 0;
  why = RefusalOf(no_side);
  EXPECT_NE(why.find("sideways"), std::string::npos) << why;
  EXPECT_NE(why.find("y column"), std::string::npos) << why;

  CalibrationData turning_only = Synthetic(TrueX(), 100, 0, 1);
  for (CalibrationPair& p : turning_only.pairs) p.u[0] = 0;
  why = RefusalOf(turning_only);
  EXPECT_NE(why.find("x column"), std::string::npos) << why;

  // One constant curvature: dtheta = 0.5 dx always.
  CalibrationData arc = Synthetic(TrueX(), 100, 0.01, 1);
  for (CalibrationPair& p : arc.pairs) p.u[2] = 0.5 * p.u[0];
  why = RefusalOf(arc);
  EXPECT_NE(why.find("dx"), std::string::npos) << why;
  EXPECT_NE(why.find("dtheta"), std::string::npos) << why;
  EXPECT_EQ(why.find("dy"), std::string::npos) << why;
}

TEST(Calibration, TextFormat) {
  std::istringstream good(
      "# raw then reference\n"
      "0.3 0.01 0.1  0.31 0.0 0.09\n"
      "\n"
      "0.2 -0.02 -0.2 0.21 -0.01 -0.19 # trailing comment\n");
  const CalibrationData d = ReadCalibrationPairs(good, "p.txt");
  ASSERT_EQ(d.pairs.size(), 2u);
  EXPECT_FALSE(d.has_information);
  EXPECT_EQ(d.pairs[1].line, 4u);
  EXPECT_EQ(d.pairs[1].u_star[2], -0.19);

  auto error_of = [](const std::string& text) {
    std::istringstream in(text);
    try {
      ReadCalibrationPairs(in, "p.txt");
    } catch (const ParseError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(error_of("1 2 3 4 5 6\n1 2 3 4 5\n").rfind("p.txt:2: ", 0), 0u);
  EXPECT_EQ(error_of("1 2 3 4 5 x6\n").rfind("p.txt:1: not a finite number", 0), 0u);
  EXPECT_EQ(error_of("1 2 3 4 5 nan\n").rfind("p.txt:1:", 0), 0u);
  // Information: all or none, and positive definite.
  EXPECT_EQ(error_of("1 2 3 4 5 6 1 0 0 1 0 1\n1 2 3 4 5 6\n").rfind("p.txt:2:", 0), 0u);
  EXPECT_EQ(error_of("1 2 3 4 5 6 1 0 0 -1 0 1\n").rfind("p.txt:1: the information", 0), 0u);
  std::istringstream info("1 2 3 4 5 6 4 1 0 2 0 9\n");
  const CalibrationData di = ReadCalibrationPairs(info, "p.txt");
  EXPECT_TRUE(di.has_information);
  EXPECT_EQ(di.pairs[0].information(1, 0), 1);
  EXPECT_EQ(di.pairs[0].information(2, 2), 9);

  // Round trip through the writer.
  std::ostringstream out;
  WriteCalibrationPairs(di, out);
  std::istringstream back(out.str());
  const CalibrationData again = ReadCalibrationPairs(back, "again");
  EXPECT_EQ(again.pairs[0].information, di.pairs[0].information);
  EXPECT_EQ(again.pairs[0].u, di.pairs[0].u);
}

TEST(Calibration, DeadReckoningWithTheTrueXRetracesTheReference) {
  std::mt19937 rng(8);
  CalibrationData data;
  data.reference_poses.push_back(SE2(1, 2, 0.3));
  const Eigen::Matrix3d x_inv = TrueX().inverse();
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d u_star = RandomIncrement(rng);
    data.reference_poses.push_back(data.reference_poses.back() * SE2::FromVector(u_star));
    data.raw_increments.push_back(x_inv * u_star);
  }
  PairsFromTrajectory(&data);
  const CalibrationResult r = Calibrate(data);
  EXPECT_LT((r.x - TrueX()).cwiseAbs().maxCoeff(), 1e-9);
  ASSERT_TRUE(r.dead_reckoning.has_value());
  EXPECT_GT(r.dead_reckoning->rms_before, 0.1);
  EXPECT_LT(r.dead_reckoning->rms_after, 1e-6);
  EXPECT_LT(r.dead_reckoning->final_after, 1e-6);
}

TEST(Calibration, FromOptimisedGraphAndItsOdometry) {
  std::mt19937 rng(9);
  PoseGraph optimised(2), raw(2);
  SE2 pose(0, 0, 0);
  const Eigen::Matrix3d x_inv = TrueX().inverse();
  optimised.AddVertex(0, pose);
  raw.AddVertex(0, pose);
  for (int k = 1; k <= 200; ++k) {
    const Eigen::Vector3d u_star = RandomIncrement(rng);
    pose = pose * SE2::FromVector(u_star);
    optimised.AddVertex(k, pose);
    raw.AddVertex(k, pose);
    Edge e;
    e.from = k - 1;
    e.to = k;
    e.z = ToParams(SE2::FromVector(x_inv * u_star));
    raw.AddEdge(e);
  }
  const std::string opt_path = TempPath("opt.g2o"), raw_path = TempPath("raw.g2o");
  WriteG2o(optimised, opt_path);
  WriteG2o(raw, raw_path);
  const CalibrationData data =
      CalibrationFromGraphs(ReadGraph(opt_path), ReadGraph(raw_path), false);
  ASSERT_EQ(data.pairs.size(), 200u);
  const CalibrationResult r = Calibrate(data);
  EXPECT_LT((r.x - TrueX()).cwiseAbs().maxCoeff(), 1e-9);
  ASSERT_TRUE(r.dead_reckoning.has_value());
  EXPECT_LT(r.dead_reckoning->rms_after, 1e-6);

  int status = 0;
  const std::string json = TempPath("g2o.json");
  RunCommand(std::string(CAIRN_TOOL) + " calibrate --quiet --g2o " + opt_path + " --odometry " +
                 raw_path + " --json " + json,
             &status);
  EXPECT_EQ(status, 0);
  std::ifstream in(json);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_LT(JsonNumber(text, "ate_rms_after"), 1e-6);
}

TEST(CalibrateTool, PairsFileJsonAndErrors) {
  const CalibrationData data = Synthetic(TrueX(), 200, 0.01, 11);
  const std::string pairs = TempPath("pairs.txt"), json = TempPath("out.json");
  WriteFileAtomically(pairs, [&](std::ostream& os) { WriteCalibrationPairs(data, os); });
  int status = 0;
  const std::string out =
      RunCommand(std::string(CAIRN_TOOL) + " calibrate " + pairs + " --json " + json, &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("Gauss-Newton"), std::string::npos);
  std::ifstream in(json);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  for (const char* key : {"\"X\"", "\"X_std\"", "\"closed_form\"", "\"gauss_newton\"", "\"ceres\""})
    EXPECT_NE(text.find(key), std::string::npos) << key;
  EXPECT_GT(JsonNumber(text, "rms_before"), JsonNumber(text, "rms_after"));
  EXPECT_LT(JsonNumber(text, "max_disagreement"), 1e-9);
  const CalibrationResult r = Calibrate(data);
  EXPECT_NEAR(JsonNumber(text, "rms_after"), r.rms_after, 1e-12);

  // A bad line: FILE:LINE on stderr, non-zero exit.
  const std::string bad = TempPath("bad.txt");
  std::ofstream(bad) << "1 2 3 4 5 6\n1 2 3 four 5 6\n";
  const std::string err = RunCommand(std::string(CAIRN_TOOL) + " calibrate " + bad + " 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(err.find(bad + ":2: "), std::string::npos) << err;

  // Degenerate: refused with the direction named, and no JSON written.
  const std::string straight = TempPath("straight.txt"), no_json = TempPath("none.json");
  {
    std::ofstream os(straight);
    for (const CalibrationPair& p : data.pairs)
      os << p.u[0] << " " << p.u[1] << " 0 " << p.u_star[0] << " " << p.u_star[1] << " 0\n";
  }
  const std::string refused = RunCommand(
      std::string(CAIRN_TOOL) + " calibrate " + straight + " --json " + no_json + " 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(refused.find("never turned"), std::string::npos) << refused;
  EXPECT_FALSE(std::filesystem::exists(no_json));

  const std::string help = RunCommand(std::string(CAIRN_TOOL) + " calibrate --help", &status);
  EXPECT_EQ(status, 0);
  for (const char* opt : {"--carmen", "--g2o", "--odometry", "--json", "--edge-information",
                          "--pairs-out", "--degeneracy-threshold", "3N - 9"})
    EXPECT_NE(help.find(opt), std::string::npos) << opt;
}

TEST(Calibration, CarmenLogReader) {
  // Two scans apart by a known motion; the ODOM chain restarts at each scan.
  const std::string log = TempPath("tiny.log");
  std::ofstream(log) << "# comment\nPARAM a 1\nODOM 0 0 0 0 0 0 0 h 0\n"
                        "FLASER 3 1 1 1 1 2 0.5 1 2 0.5 0 h 0\n"
                        "ODOM 1 2 0.5 0 0 0 0 h 0\nODOM 1.2 2.1 0.6 0 0 0 0 h 0\n"
                        "FLASER 3 1 1 1 1.25 2.1 0.62 1.25 2.1 0.62 1 h 1\n"
                        "FLASER 3 1 1 1 1.3 2.2 0.7 1.3 2.2 0.7 2 h 2\n";
  const CalibrationData d = ReadCarmenCalibration(log);
  ASSERT_EQ(d.reference_poses.size(), 3u);
  ASSERT_EQ(d.raw_increments.size(), 2u);
  const Eigen::Vector3d u = SE2(1, 2, 0.5).Between(SE2(1.2, 2.1, 0.6)).ToVector();
  EXPECT_LT((d.raw_increments[0] - u).norm(), 1e-12);
  EXPECT_EQ(d.steps_without_odometry, 1u);
  ASSERT_EQ(d.pairs.size(), 1u);
  EXPECT_LT((d.pairs[0].u_star - SE2(1, 2, 0.5).Between(SE2(1.25, 2.1, 0.62)).ToVector()).norm(),
            1e-12);

  const std::string bad = TempPath("bad.log");
  std::ofstream(bad) << "FLASER 3 1 1 1 1 2 0.5 1 2 0.5 0 h 0\nODOM 1 2 x\nFLASER 3 1 1\n";
  try {
    ReadCarmenCalibration(bad);
    ADD_FAILURE() << "accepted a bad log";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 2u) << e.what();
  }
}

TEST(Calibration, IntelLogLowersDeadReckoningError) {
  const std::string log = DatasetPath("carmen/intel-corrected.log.gz");
  CAIRN_REQUIRE_DATASET(log);
  const CalibrationData data = ReadCarmenCalibration(log);
  EXPECT_EQ(data.reference_poses.size(), 910u);
  const CalibrationResult r = Calibrate(data);
  EXPECT_LT(r.max_disagreement, 1e-9);
  EXPECT_LT(r.rms_after, r.rms_before);
  ASSERT_TRUE(r.dead_reckoning.has_value());
  EXPECT_LT(r.dead_reckoning->rms_after, r.dead_reckoning->rms_before);
  std::cout << "intel: ATE RMS " << r.dead_reckoning->rms_before << " -> "
            << r.dead_reckoning->rms_after << " m, final " << r.dead_reckoning->final_before
            << " -> " << r.dead_reckoning->final_after << " m\nX =\n"
            << r.x << "\n";

  int status = 0;
  const std::string json = TempPath("intel.json");
  RunCommand(std::string(CAIRN_TOOL) + " calibrate --quiet --carmen " + log + " --json " + json,
             &status);
  EXPECT_EQ(status, 0);
  std::ifstream in(json);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NEAR(JsonNumber(text, "ate_rms_after"), r.dead_reckoning->rms_after, 1e-9);
}

}  // namespace
}  // namespace cairn
