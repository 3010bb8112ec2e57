// Trajectory errors in space and in the plane: what a z error does to the
// ATE, alignments (none, rigid, with scale), pairing by nearest stamp, the
// rotational RPE, and the planar path against its 3D lift.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "cairn/frontend/trajectory.h"
#include "cairn/frontend/trajectory_eval.h"
#include "cairn/graph/text_input.h"
#include "test_util.h"

namespace cairn::frontend {
namespace {

SE3 Pose(double x, double y, double z, double roll, double pitch, double yaw) {
  Vector6d v;
  v << x, y, z, roll, pitch, yaw;
  return SE3::FromEulerVector(v);
}

// A climbing, banking, wavering path: no two poses alike, not in a plane.
Trajectory Helix(int n = 200, double dt = 0.1) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 0.05 * i;
    t.Add(100 + dt * i, Pose(5 * std::cos(a), 5 * std::sin(a), 0.02 * i + 0.3 * std::sin(3 * a),
                             0.2 * std::sin(a), 0.1 * std::cos(2 * a), a + M_PI / 2));
  }
  return t;
}

Trajectory Moved(const Trajectory& t, const SE3& motion, double scale = 1, double dt = 0) {
  Trajectory out;
  for (size_t i = 0; i < t.size(); ++i) {
    const SE3& p = t.poses3d[i];
    out.Add(t.stamps[i] + dt, motion * SE3(p.rotation(), scale * p.translation()));
  }
  return out;
}

TEST(TrajectoryEval3D, ZOffByUpToTwoMetresIsSeen) {
  const Trajectory ref = Helix();
  Trajectory est;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> dz(-2, 2);
  for (size_t i = 0; i < ref.size(); ++i) {
    const SE3& p = ref.poses3d[i];
    est.Add(ref.stamps[i], SE3(p.rotation(), p.translation() + Eigen::Vector3d(0, 0, dz(rng))));
  }
  ASSERT_EQ(est.dimension, 3);
  const TrajectoryErrors e = EvaluateTrajectory(est, ref);
  EXPECT_EQ(e.dimension, 3);
  EXPECT_EQ(e.matched, ref.size());
  EXPECT_GT(e.ate_rmse, 1.0);
  EXPECT_LE(e.ate.max, 2.0 + 0.5);
  EXPECT_GT(e.rpe_trans_rmse, 1.0);
  // The planar view alone (what eval saw before) would not see it at all.
  Trajectory est2d, ref2d;
  for (size_t i = 0; i < ref.size(); ++i) {
    est2d.Add(est.stamps[i], est.poses[i]);
    ref2d.Add(ref.stamps[i], ref.poses[i]);
  }
  EXPECT_LT(EvaluateTrajectory(est2d, ref2d).ate_rmse, 1e-9);
}

TEST(TrajectoryEval3D, RigidlyMovedCopyHasNoErrorUnderSe3) {
  const Trajectory ref = Helix();
  const SE3 motion = Pose(12, -7, 3, 0.4, -0.3, 2.0);
  const Trajectory est = Moved(ref, motion);
  const TrajectoryErrors e = EvaluateTrajectory(est, ref);
  EXPECT_EQ(e.matched, ref.size());
  EXPECT_NEAR(e.ate_rmse, 0, 1e-9);
  EXPECT_NEAR(e.ate_rot_deg.rmse, 0, 1e-6);
  EXPECT_NEAR(e.rpe_trans_rmse, 0, 1e-9);
  EXPECT_NEAR(e.rpe_rot_rmse_deg, 0, 1e-6);
  EXPECT_GT(e.rpe_pairs, 50u);
  EXPECT_DOUBLE_EQ(e.scale, 1);
  // Without alignment the motion itself is the error.
  EvalOptions none;
  none.align = Alignment::kNone;
  const TrajectoryErrors raw = EvaluateTrajectory(est, ref, none);
  EXPECT_GT(raw.ate_rmse, 5);
  EXPECT_GT(raw.ate_rot_deg.rmse, 10);
  EXPECT_NEAR(raw.rpe_trans_rmse, 0, 1e-9);  // relative motion does not see it
}

TEST(TrajectoryEval3D, Sim3RecoversTheScale) {
  const Trajectory ref = Helix();
  const Trajectory est = Moved(ref, Pose(1, 2, 3, 0.1, 0.2, 0.3), 0.4);
  EvalOptions sim3;
  sim3.align = Alignment::kSimilarity;
  const TrajectoryErrors e = EvaluateTrajectory(est, ref, sim3);
  EXPECT_NEAR(e.scale, 1 / 0.4, 1e-9);
  EXPECT_NEAR(e.ate_rmse, 0, 1e-9);
  EXPECT_NEAR(e.rpe_trans_rmse, 0, 1e-9);  // relative motions scaled as well
  const TrajectoryErrors rigid = EvaluateTrajectory(est, ref);
  EXPECT_GT(rigid.ate_rmse, 1);
  EXPECT_GT(rigid.rpe_trans_rmse, 0.1);
}

TEST(TrajectoryEval2D, Sim3RecoversTheScaleInThePlane) {
  Trajectory ref, est;
  const SE2 offset(3, -1, 0.7);
  for (int i = 0; i < 100; ++i) {
    const SE2 p(0.2 * i, std::sin(0.1 * i), 0.05 * i);
    ref.Add(i, p);
    const SE2 q = offset * SE2(2.5 * p.x(), 2.5 * p.y(), p.theta());
    est.Add(i, q);
  }
  EvalOptions sim3;
  sim3.align = Alignment::kSimilarity;
  const TrajectoryErrors e = EvaluateTrajectory(est, ref, sim3);
  EXPECT_EQ(e.dimension, 2);
  EXPECT_NEAR(e.scale, 1 / 2.5, 1e-9);
  EXPECT_NEAR(e.ate_rmse, 0, 1e-9);
  EXPECT_NEAR(e.rpe_trans_rmse, 0, 1e-9);
}

TEST(TrajectoryEval, StampsFourMillisecondsApartPairWithinTheDefaultTolerance) {
  const Trajectory ref = Helix(150, 0.1);
  const Trajectory est = Moved(ref, SE3(), 1, 0.004);
  EXPECT_EQ(Associate(est, ref).size(), ref.size());
  const TrajectoryErrors e = EvaluateTrajectory(est, ref);
  EXPECT_EQ(e.matched, ref.size());
  EXPECT_EQ(e.unpaired_est, 0u);
  EXPECT_EQ(e.unpaired_ref, 0u);
  EXPECT_NEAR(e.ate_rmse, 0, 1e-9);
  EXPECT_TRUE(Associate(est, ref, 0.001).empty());
  EvalOptions tight;
  tight.max_dt = 0.001;
  const TrajectoryErrors none = EvaluateTrajectory(est, ref, tight);
  EXPECT_EQ(none.matched, 0u);
  EXPECT_EQ(none.unpaired_ref, ref.size());
}

TEST(TrajectoryEval, EachReferencePoseIsUsedOnceAndTheNearestWins) {
  Trajectory ref, est;
  for (int i = 0; i < 10; ++i) ref.Add(i * 0.1, SE2(i, 0, 0));
  // Two estimate poses around each reference stamp: 3 ms early, 6 ms late.
  for (int i = 0; i < 10; ++i) {
    est.Add(i * 0.1 - 0.003, SE2(i, 0, 0));
    est.Add(i * 0.1 + 0.006, SE2(i, 0, 0));
  }
  const auto pairs = Associate(est, ref);
  ASSERT_EQ(pairs.size(), ref.size());
  for (size_t k = 0; k < pairs.size(); ++k) EXPECT_EQ(pairs[k], std::make_pair(2 * k, k));
  const TrajectoryErrors e = EvaluateTrajectory(est, ref);
  EXPECT_EQ(e.unpaired_est, 10u);
  EXPECT_EQ(e.unpaired_ref, 0u);
}

TEST(TrajectoryEval3D, RotationalRpeOfAKnownErrorPerStep) {
  // Each estimated step is the reference's step followed by a rotation of
  // delta about a tilted axis: the error of every one-step segment is delta.
  const double delta = 0.02;
  const SE3 twist(Eigen::Quaterniond(Eigen::AngleAxisd(delta, Eigen::Vector3d(1, 2, 3).normalized())),
                  Eigen::Vector3d::Zero());
  Trajectory ref, est;
  SE3 r, x;
  for (int i = 0; i < 120; ++i) {
    ref.Add(i, r);
    est.Add(i, x);
    const SE3 step = Pose(1, 0, 0.1, 0.05, -0.02, 0.1 * std::sin(0.2 * i));
    r = r * step;
    x = x * step * twist;
  }
  EvalOptions opt;
  opt.segment = 0.5;  // every step is about 1 m: each segment is one step
  const TrajectoryErrors e = EvaluateTrajectory(est, ref, opt);
  EXPECT_EQ(e.dimension, 3);
  EXPECT_EQ(e.rpe_pairs, ref.size() - 1);
  EXPECT_NEAR(e.rpe_rot_rmse_deg, delta * 180 / M_PI, 1e-9);
  EXPECT_NEAR(e.rpe_rot_deg.max, delta * 180 / M_PI, 1e-9);
  EXPECT_NEAR(e.rpe_rot_deg.min, delta * 180 / M_PI, 1e-9);
  EXPECT_NEAR(e.rpe_trans_rmse, 0, 1e-9);
  EXPECT_GT(e.ate_rmse, 0.1);  // the twist accumulates into a different path
}

TEST(TrajectoryEval2D, RotationalRpeOfAKnownHeadingErrorPerStep) {
  const double delta = 0.01;
  Trajectory ref, est;
  SE2 r, x;
  for (int i = 0; i < 80; ++i) {
    ref.Add(i, r);
    est.Add(i, x);
    const SE2 step(1, 0, 0.05);
    r = r * step;
    x = x * step * SE2(0, 0, delta);
  }
  EvalOptions opt;
  opt.segment = 0.5;
  const TrajectoryErrors e = EvaluateTrajectory(est, ref, opt);
  EXPECT_EQ(e.dimension, 2);
  EXPECT_NEAR(e.rpe_rot_rmse_deg, delta * 180 / M_PI, 1e-9);
  EXPECT_NEAR(e.rpe_trans_rmse, 0, 1e-9);
}

// A planar pair evaluates alike in the plane and lifted into space; a planar
// estimate against a 3D reference is taken at z = 0, level.
TEST(TrajectoryEval, PlanarPathAgreesWithItsLift) {
  Trajectory ref, est, ref3d;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.05);
  const SE2 offset(4, 1, -0.6);
  for (int i = 0; i < 150; ++i) {
    const SE2 p(0.1 * i, 2 * std::sin(0.05 * i), 0.04 * i);
    ref.Add(i, p);
    ref3d.Add(i, Lift(p));
    est.Add(i, offset * SE2(p.x() + noise(rng), p.y() + noise(rng), p.theta() + noise(rng)));
  }
  ref3d.dimension = 3;  // as a 3D graph that lies in the plane
  const TrajectoryErrors planar = EvaluateTrajectory(est, ref);
  const TrajectoryErrors lifted = EvaluateTrajectory(est, ref3d);
  EXPECT_EQ(planar.dimension, 2);
  EXPECT_EQ(lifted.dimension, 3);
  EXPECT_GT(planar.ate_rmse, 0.03);
  EXPECT_NEAR(lifted.ate_rmse, planar.ate_rmse, 1e-9);
  EXPECT_NEAR(lifted.rpe_trans_rmse, planar.rpe_trans_rmse, 1e-9);
  EXPECT_NEAR(lifted.rpe_rot_rmse_deg, planar.rpe_rot_rmse_deg, 1e-7);
  EXPECT_NEAR(lifted.ate_rot_deg.rmse, planar.ate_rot_deg.rmse, 1e-7);
}

TEST(TrajectoryEval, StatisticsAreEvos) {
  Trajectory ref, est;
  const double dx[] = {0.1, -0.3, 0.2, 0.0, 0.4};
  for (int i = 0; i < 5; ++i) {
    ref.Add(i, SE2(i, 0, 0));
    est.Add(i, SE2(i + dx[i], 0, 0));
  }
  EvalOptions none;
  none.align = Alignment::kNone;
  const ErrorStats s = EvaluateTrajectory(est, ref, none).ate;
  double sq = 0, sum = 0;
  for (double d : dx) {
    sq += d * d;
    sum += std::abs(d);
  }
  EXPECT_NEAR(s.rmse, std::sqrt(sq / 5), 1e-12);
  EXPECT_NEAR(s.mean, sum / 5, 1e-12);
  EXPECT_NEAR(s.median, 0.2, 1e-12);
  EXPECT_NEAR(s.min, 0.0, 1e-12);
  EXPECT_NEAR(s.max, 0.4, 1e-12);
  EXPECT_NEAR(s.std, std::sqrt(sq / 5 - (sum / 5) * (sum / 5)), 1e-12);
  EXPECT_EQ(s.count, 5u);
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = cairn::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(TrajectoryRead, TumIn3DAndInThePlane) {
  const std::string flat = WriteTemp("flat.tum", "# t x y z qx qy qz qw\n1.0 1 2 0 0 0 0.3826834 0.9238795\n");
  EXPECT_EQ(ReadTrajectory(flat).dimension, 2);
  const std::string up = WriteTemp("up.tum", "1.0 1 2 0 0 0 0 1\n\n2.0 1 2 3 0 0 0 1\n");
  const Trajectory t = ReadTrajectory(up);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.dimension, 3);
  EXPECT_DOUBLE_EQ(t.poses3d[1].translation().z(), 3);
  const std::string tilted = WriteTemp("tilt.tum", "1.0 1 2 0 0.0998334 0 0 0.9950042\n");
  EXPECT_EQ(ReadTrajectory(tilted).dimension, 3);
}

void ExpectTumError(const std::string& name, const std::string& text, size_t line, const std::string& what) {
  const std::string path = WriteTemp(name, text);
  try {
    ReadTrajectory(path);
    ADD_FAILURE() << "no error for " << name;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(path + ":" + std::to_string(line) + ": "), std::string::npos);
    EXPECT_NE(e.message().find(what), std::string::npos) << e.what();
  }
}

TEST(TrajectoryRead, MalformedTumLinesNameFileAndLine) {
  const std::string good = "1.0 1 2 3 0 0 0 1\n";
  ExpectTumError("short.tum", good + "2.0 1 2 3 0 0 1\n", 2, "expected");
  ExpectTumError("extra.tum", good + good + "3.0 1 2 3 0 0 0 1 9\n", 3, "unexpected field");
  ExpectTumError("stamp.tum", "# c\nx1.0 1 2 3 0 0 0 1\n", 2, "bad timestamp");
  ExpectTumError("zero.tum", good + "2.0 1 2 3 0 0 0 0\n", 2, "zero quaternion");
  ExpectTumError("norm.tum", good + "2.0 1 2 3 0 0 0 2\n", 2, "far from unit length");
  ExpectTumError("far.tum", good + "2.0 1 2 3e12 0 0 0 1\n", 2, "beyond");
  ExpectTumError("ns.tum", good + "1700000000000000000 1 2 3 0 0 0 1\n", 2, "TUM stamps are seconds");
}

TEST(TrajectoryRead, A3DGraphIsA3DTrajectory) {
  const std::string g2o = WriteTemp(
      "g3.g2o",
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0.5 0 0 0 1\n"
      "EDGE_SE3:QUAT 0 1 1 0 0.5 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n");
  const Trajectory t = ReadTrajectory(g2o);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.dimension, 3);
  EXPECT_TRUE(t.stamps_are_ids);
  EXPECT_DOUBLE_EQ(t.poses3d[1].translation().z(), 0.5);
}

}  // namespace
}  // namespace cairn::frontend
