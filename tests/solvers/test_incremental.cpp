// Incremental use: a graph fed one pose at a time and optimised along the
// way reaches the batch solvers' optimum, with either solver; the Gauss-Newton
// path reuses its ordering while the graph only grows; the gauge follows a
// prior that arrives late.
#include <gtest/gtest.h>

#include <cmath>

#include "cairn/graph/chi2.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/incremental.h"
#include "cairn/graph/simulate.h"

namespace cairn {
namespace {

IncrementalOptions Tight() {
  IncrementalOptions o;
  for (SolverOptions* s : {static_cast<SolverOptions*>(&o.ceres),
                           static_cast<SolverOptions*>(&o.gauss_newton)}) {
    s->function_tolerance = 1e-12;
    s->parameter_tolerance = 1e-12;
    s->threads = 1;
  }
  return o;
}

Simulation Small(int dimension, int poses) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = poses;
  o.nodes_per_lap = 20;
  o.seed = 5;
  return Simulate(o);
}

// Feeds the simulated graph pose by pose (each pose with the edges that end
// at it, its estimate from the last pose and the odometry), optimising every
// `every` poses; returns the final chi2.
template <typename Pose>
double Feed(const Simulation& sim, IncrementalOptimizer& opt, SolverKind solver, int every,
            int* optimisations) {
  const PoseGraph& g = sim.noisy;
  const auto& edges = g.edges();
  size_t k = 0;
  *optimisations = 0;
  double chi2 = 0;
  for (int64_t i = 0; i < static_cast<int64_t>(g.vertices().size()); ++i) {
    if (i == 0) {
      opt.AddPose(0, ToPose<Pose>(g.vertex(0).x));
    } else {
      // Dead reckoning from the current (optimised) estimate of the last pose.
      const Edge& odo = edges[k];
      EXPECT_EQ(odo.to, i);
      Pose z;
      if constexpr (std::is_same_v<Pose, SE2>) z = ToSE2(odo.z); else z = ToSE3(odo.z);
      opt.AddPose(i, ToPose<Pose>(opt.graph().vertex(i - 1).x) * z);
    }
    for (; k < edges.size() && std::max(edges[k].from, edges[k].to) <= i; ++k)
      opt.AddEdge(edges[k]);
    if (i > 0 && (i % every == 0 || i + 1 == static_cast<int64_t>(g.vertices().size()))) {
      const SolveResult r = opt.Optimize(solver);
      EXPECT_TRUE(r.usable) << r.message;
      chi2 = r.final_chi2;
      ++*optimisations;
    }
  }
  return chi2;
}

double BatchChi2(const Simulation& sim) {
  PoseGraph g = sim.noisy;
  GaussNewtonOptions o = Tight().gauss_newton;
  const SolveResult r = SolveGaussNewton(g, o);
  EXPECT_TRUE(r.converged) << r.message;
  return r.final_chi2;
}

TEST(Incremental, GaussNewton2DReachesTheBatchOptimum) {
  const Simulation sim = Small(2, 400);
  IncrementalOptimizer opt(2, Tight());
  int n = 0;
  const double chi2 = Feed<SE2>(sim, opt, SolverKind::kGaussNewton, 25, &n);
  EXPECT_NEAR(chi2, BatchChi2(sim), 1e-6 * chi2);
  EXPECT_EQ(opt.graph().edges().size(), sim.noisy.edges().size());
  // The ordering is computed afresh only when the graph has grown by 10%;
  // in between, each new pose arrives with edges to older ones only, so the
  // analysis is extended rather than redone.
  EXPECT_LT(opt.gauss_newton_reorderings(), n);
  EXPECT_GT(opt.gauss_newton_reorderings(), 1);
  EXPECT_EQ(opt.gauss_newton_reorderings() + opt.gauss_newton_extensions(), n);
}

TEST(Incremental, LoopClosureBetweenOldPosesStillReachesTheOptimum) {
  const Simulation sim = Small(2, 200);
  IncrementalOptimizer opt(2, Tight());
  int n = 0;
  Feed<SE2>(sim, opt, SolverKind::kGaussNewton, 199, &n);
  const int extensions = opt.gauss_newton_extensions();
  // A closure between two poses already optimised adds a block of H in an
  // old column: the analysis cannot be extended, and is redone.
  PoseGraph batch = sim.noisy;
  const Edge closure = batch.edges()[batch.edges().size() / 2];  // its measurement and information
  Edge extra = closure;
  extra.from = 3;
  extra.to = 150;
  extra.kind = EdgeKind::kLoopClosure;
  opt.AddEdge(extra);
  batch.AddEdge(extra);
  const SolveResult r = opt.Optimize(SolverKind::kGaussNewton);
  EXPECT_EQ(opt.gauss_newton_extensions(), extensions);
  GaussNewtonOptions o = Tight().gauss_newton;
  const SolveResult b = SolveGaussNewton(batch, o);
  EXPECT_NEAR(r.final_chi2, b.final_chi2, 1e-6 * b.final_chi2);
}

TEST(Incremental, Ceres2DReachesTheBatchOptimum) {
  const Simulation sim = Small(2, 300);
  IncrementalOptimizer opt(2, Tight());
  int n = 0;
  const double chi2 = Feed<SE2>(sim, opt, SolverKind::kCeres, 30, &n);
  EXPECT_NEAR(chi2, BatchChi2(sim), 1e-6 * chi2);
}

TEST(Incremental, SolversCanAlternate3D) {
  const Simulation sim = Small(3, 200);
  IncrementalOptimizer opt(3, Tight());
  int n = 0;
  Feed<SE3>(sim, opt, SolverKind::kGaussNewton, 40, &n);
  // Ceres starts from the Gauss-Newton optimum: nothing left to gain.
  const SolveResult r = opt.Optimize(SolverKind::kCeres);
  EXPECT_NEAR(r.final_chi2, BatchChi2(sim), 1e-6 * r.final_chi2);
  EXPECT_NEAR(r.final_chi2, r.initial_chi2, 1e-6 * r.final_chi2);
}

TEST(Incremental, WarmStartNeedsFewIterations) {
  const Simulation sim = Small(2, 400);
  IncrementalOptimizer opt(2, IncrementalOptions{});
  int n = 0;
  Feed<SE2>(sim, opt, SolverKind::kGaussNewton, 399, &n);
  // One more pose by odometry: the optimum moves only by that pose.
  const int64_t last = static_cast<int64_t>(sim.noisy.vertices().size()) - 1;
  const SE2 z(1.0, 0.0, 0.0);
  opt.AddPose(last + 1, opt.PoseSE2(last) * z);
  opt.AddOdometry(last, last + 1, z, Eigen::Matrix3d::Identity() * 100);
  const SolveResult r = opt.Optimize(SolverKind::kGaussNewton);
  EXPECT_LE(r.iterations, 2);
  EXPECT_NEAR(r.final_chi2, r.initial_chi2, 1e-9 * (1 + r.final_chi2));
}

TEST(Incremental, LatePriorMovesTheGauge) {
  IncrementalOptimizer opt(2, Tight());
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity() * 100;
  opt.AddPose(0, SE2(0, 0, 0));
  opt.AddPose(1, SE2(1, 0, 0));
  opt.AddOdometry(0, 1, SE2(1, 0, 0), info);
  for (SolverKind s : {SolverKind::kGaussNewton, SolverKind::kCeres}) {
    IncrementalOptimizer o2(opt.graph(), Tight());
    o2.Optimize(s);
    // Held as the gauge: vertex 0 stays where it was put.
    EXPECT_NEAR(o2.PoseSE2(0).x(), 0, 1e-12);
    o2.AddPrior(0, SE2(5, 0, 0), info);
    o2.Optimize(s);
    // The prior now anchors the graph and pulls vertex 0 with vertex 1.
    EXPECT_NEAR(o2.PoseSE2(0).x(), 5, 1e-6);
    EXPECT_NEAR(o2.PoseSE2(1).x(), 6, 1e-6);
  }
}

TEST(Incremental, RejectsBadInput) {
  IncrementalOptimizer opt(2);
  opt.AddPose(0, SE2());
  EXPECT_THROW(opt.AddPose(0, SE2()), std::invalid_argument);
  EXPECT_THROW(opt.AddPose(1, SE3()), std::invalid_argument);
  EXPECT_THROW(opt.AddOdometry(0, 7, SE2(), Eigen::Matrix3d::Identity()), std::invalid_argument);
}

}  // namespace
}  // namespace cairn
