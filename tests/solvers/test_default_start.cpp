// The default start (InitMethod::kAuto): on graphs whose odometry-chained
// vertices lead both solvers into a bad local minimum, it takes the chordal
// relaxation and reaches the good one; where the file's vertices are better
// it keeps them. With a robust kernel on loop closures it compares the
// starts by the kernel's cost, which wrong loop closures do not dominate.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "cairn/graph/chi2.h"
#include "cairn/graph/initialization.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/solvers/graph_gauss_newton.h"

namespace cairn {
namespace {

// Strong heading noise: chained odometry drifts by tens of degrees.
Simulation HeadingNoise(uint64_t seed) {
  SimulationOptions o;
  o.poses = 3000;
  o.rotation_noise = 0.1;
  o.seed = seed;
  return Simulate(o);
}

Eigen::Vector2d Position(const Vertex& v) { return Eigen::Vector2d(v.x[0], v.x[1]); }

// ATE: the RMS position error after the best rigid alignment of the
// estimate onto the truth (2D, closed form), as `cairn eval` reports it.
double Ate(const PoseGraph& estimate, const PoseGraph& truth) {
  const size_t n = estimate.vertices().size();
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < n; ++i) {
    ca += Position(estimate.vertices()[i]);
    cb += Position(truth.vertex(estimate.vertices()[i].id));
  }
  ca /= n;
  cb /= n;
  double dot = 0, cross = 0;  // the rotation that best maps a onto b
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = Position(estimate.vertices()[i]) - ca;
    const Eigen::Vector2d b = Position(truth.vertex(estimate.vertices()[i].id)) - cb;
    dot += a.dot(b);
    cross += a.x() * b.y() - a.y() * b.x();
  }
  const Eigen::Rotation2Dd r(std::atan2(cross, dot));
  double sum = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = Position(estimate.vertices()[i]) - ca;
    const Eigen::Vector2d b = Position(truth.vertex(estimate.vertices()[i].id)) - cb;
    sum += (r * a - b).squaredNorm();
  }
  return std::sqrt(sum / n);
}

SolveResult Solve(PoseGraph& graph, bool gn, const RobustLoss& loss = {}) {
  SolverOptions common;
  common.threads = 1;
  common.loop_closure_loss = loss;
  if (gn) {
    GaussNewtonOptions o;
    static_cast<SolverOptions&>(o) = common;
    return SolveGaussNewton(graph, o);
  }
  CeresOptions o;
  static_cast<SolverOptions&>(o) = common;
  return SolveWithCeres(graph, o);
}

class HeadingNoiseSeed : public ::testing::TestWithParam<uint64_t> {};

TEST_P(HeadingNoiseSeed, AutoStartReachesTheGoodMinimum) {
  const Simulation sim = HeadingNoise(GetParam());
  for (bool gn : {true, false}) {
    SCOPED_TRACE(gn ? "gn" : "ceres");
    PoseGraph from_file = sim.noisy;
    ASSERT_EQ(Initialize(from_file, InitMethod::kFile).chosen, InitMethod::kFile);
    const SolveResult rf = Solve(from_file, gn);
    const double error_file = Ate(from_file, sim.truth);

    PoseGraph from_auto = sim.noisy;
    const InitReport init = Initialize(from_auto, InitMethod::kAuto);
    EXPECT_EQ(init.method, InitMethod::kAuto);
    EXPECT_EQ(init.chosen, InitMethod::kChordal);
    EXPECT_LT(init.chordal_chi2, init.file_chi2);
    EXPECT_DOUBLE_EQ(init.chi2, init.chordal_chi2);
    const SolveResult ra = Solve(from_auto, gn);
    const double error_auto = Ate(from_auto, sim.truth);

    // The file's start ends metres off, in a minimum of far higher chi2...
    EXPECT_GT(error_file, 3.0) << rf.message;
    // ... the default start in the good one (ATE 0.35 to 0.7 m).
    EXPECT_LT(error_auto, 1.0) << ra.message;
    EXPECT_TRUE(ra.converged) << ra.message;
    EXPECT_LT(ra.final_chi2, 0.2 * rf.final_chi2);
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, HeadingNoiseSeed, ::testing::Values(1, 2, 3));

TEST(AutoStart, KeepsTheFileWhenItIsBetter) {
  SimulationOptions o;
  o.poses = 300;
  o.seed = 4;
  Simulation sim = Simulate(o);
  // An optimum: chordal cannot beat it.
  PoseGraph optimum = sim.noisy;
  Initialize(optimum, InitMethod::kChordal);
  ASSERT_TRUE(Solve(optimum, true).converged);
  PoseGraph graph = optimum;
  const InitReport init = Initialize(graph, InitMethod::kAuto);
  EXPECT_EQ(init.chosen, InitMethod::kFile);
  EXPECT_LT(init.file_chi2, init.chordal_chi2);
  EXPECT_EQ(init.chi2, init.file_chi2);
  EXPECT_EQ(ComparePoses(graph, optimum).max_translation, 0.0);
  EXPECT_NE(DescribeAutoChoice(init).find("file"), std::string::npos);
}

// With wrong loop closures and a robust kernel: the relaxation weighs every
// loop closure fully and is bent by the wrong ones, yet its plain chi2 is far
// below the odometry start's (whose wrong loop closures are far off). By the
// kernel's own cost the odometry start is the better, and DCS from there
// ends near the truth where from the bent relaxation it ends 12-27 m off
// (seeds 1, 2, 4, 7, 8). Not always: on seeds 3, 5 and 6 both starts end in
// poor minima, the relaxation's 0.4-2.6 m off and the odometry's 2.5-3.6 m
// (this simulation's odometry drifts far and DCS at phi 1 pulls weakly).
// So the test is over eight seeds: each choice, and the error summed.
TEST(AutoStart, WithAKernelComparesTheRobustCost) {
  RobustLoss dcs;
  dcs.kind = RobustLoss::kDcs;
  dcs.delta = 1;
  for (bool gn : {true, false}) {
    SCOPED_TRACE(gn ? "gn" : "ceres");
    double error_plain = 0, error_robust = 0;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
      SCOPED_TRACE(seed);
      SimulationOptions o;
      o.poses = 1000;
      o.outliers = 150;
      o.seed = seed;
      const Simulation sim = Simulate(o);

      PoseGraph plain = sim.noisy;
      const InitReport by_chi2 = Initialize(plain, InitMethod::kAuto);
      EXPECT_EQ(by_chi2.chosen, InitMethod::kChordal);  // the trap
      EXPECT_FALSE(by_chi2.robust_cost);

      PoseGraph robust = sim.noisy;
      const InitReport by_cost = Initialize(robust, InitMethod::kAuto, LossOfChi2(dcs));
      EXPECT_TRUE(by_cost.robust_cost);
      EXPECT_EQ(by_cost.chosen, InitMethod::kFile);
      EXPECT_LT(by_cost.file_chi2, 1e-2 * by_cost.chordal_chi2);
      EXPECT_DOUBLE_EQ(by_cost.chi2, Chi2(sim.noisy));  // the plain chi2 of the start kept
      EXPECT_NE(DescribeAutoChoice(by_cost).find("robust cost"), std::string::npos);

      EXPECT_TRUE(Solve(plain, gn, dcs).usable);
      EXPECT_TRUE(Solve(robust, gn, dcs).usable);
      error_plain += Ate(plain, sim.truth);
      error_robust += Ate(robust, sim.truth);
    }
    // Summed over the seeds: about 100 m from the relaxation, 15 m now.
    EXPECT_GT(error_plain, 50.0);
    EXPECT_LT(error_robust, 0.25 * error_plain);
  }
}

TEST(AutoStart, ParsesAndNames) {
  EXPECT_EQ(ParseInitMethod("auto"), InitMethod::kAuto);
  EXPECT_STREQ(ToString(InitMethod::kAuto), "auto");
}

}  // namespace
}  // namespace cairn
