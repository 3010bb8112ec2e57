// Both solvers on graphs with point landmarks: the same optimum on simulated
// landmark graphs (2D and 3D) near the ground truth, poses tied only
// through landmarks solved as one component, and landmark covariances that
// agree between the two paths and with a hand computation.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/graph/simulate.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/covariance.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/incremental.h"

namespace cairn {
namespace {

Simulation WithLandmarks(int dimension, uint64_t seed) {
  SimulationOptions o;
  o.dimension = dimension;
  o.poses = dimension == 2 ? 200 : 150;
  o.nodes_per_lap = 25;
  o.radius = 15;
  o.landmarks = 40;
  o.seed = seed;
  return Simulate(o);
}

// RMS distance of the landmarks from their true positions.
double LandmarkRms(const PoseGraph& est, const PoseGraph& truth) {
  double sum = 0;
  for (const Vertex& v : est.vertices()) {
    if (!v.landmark) continue;
    for (int k = 0; k < est.dimension(); ++k) {
      const double d = v.x[k] - truth.vertex(v.id).x[k];
      sum += d * d;
    }
  }
  return std::sqrt(sum / est.CountLandmarks());
}

void ExpectSolversAgree(int dimension) {
  for (uint64_t seed : {1, 2}) {
    const Simulation sim = WithLandmarks(dimension, seed);
    ASSERT_GT(sim.noisy.CountEdges(EdgeKind::kLandmark), sim.noisy.CountLandmarks());
    PoseGraph ceres = sim.noisy, gn = sim.noisy;
    CeresOptions co;
    co.function_tolerance = 1e-12;
    GaussNewtonOptions go;
    go.function_tolerance = 1e-12;
    const SolveResult rc = SolveWithCeres(ceres, co);
    const SolveResult rg = SolveGaussNewton(gn, go);
    ASSERT_TRUE(rc.usable) << rc.message;
    ASSERT_TRUE(rg.converged) << rg.message;
    EXPECT_LT(rg.final_chi2, 0.2 * rg.initial_chi2);  // odometry drift taken out
    EXPECT_NEAR(rc.final_chi2, rg.final_chi2, 1e-6 * rg.final_chi2) << "seed " << seed;
    // The drifted start is far off; the optimum is near the truth. The gauge
    // is pose 0, held at its true pose in both.
    const double before = LandmarkRms(sim.noisy, sim.truth), after = LandmarkRms(gn, sim.truth);
    EXPECT_LT(after, 0.5 * before) << "seed " << seed;
    EXPECT_LT(after, 1.0) << "seed " << seed;
    EXPECT_LT(LandmarkRms(ceres, gn), 1e-4) << "seed " << seed;
  }
}

TEST(LandmarkSolvers, BothSolversAgreeNearTheTruth2D) { ExpectSolversAgree(2); }
TEST(LandmarkSolvers, BothSolversAgreeNearTheTruth3D) { ExpectSolversAgree(3); }

// Two odometry chains that see the same three landmarks and nothing else in
// common: one component, one gauge; the normal equations are not singular.
PoseGraph TwoChains() {
  PoseGraph g(2);
  const SE2 truth[4] = {SE2(0, 0, 0), SE2(1, 0, 0.1), SE2(0, 3, -0.3), SE2(1, 3, -0.2)};
  const Eigen::Vector2d points[3] = {{0.5, 1.5}, {2, 1}, {-1, 2}};
  for (int i = 0; i < 4; ++i) g.AddVertex(i, SE2(truth[i].x() + 0.1, truth[i].y() - 0.2, 0));
  for (int k = 0; k < 3; ++k) g.AddLandmark(10 + k, Eigen::Vector3d::Zero());
  for (int i : {0, 2}) {
    Edge e;
    e.from = i;
    e.to = i + 1;
    e.z = ToParams(truth[i].Between(truth[i + 1]));
    g.AddEdge(e);
  }
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) {
      Edge e;
      e.kind = EdgeKind::kLandmark;
      e.from = i;
      e.to = 10 + k;
      const Eigen::Vector2d z = truth[i].Inverse() * points[k];
      e.z = {z.x(), z.y(), 0, 0, 0, 0, 0};
      g.AddEdge(e);
    }
  g.vertex(0).x = ToParams(truth[0]);
  PlaceLandmarks(g);
  return g;
}

TEST(LandmarkSolvers, PosesTiedOnlyThroughLandmarksAreSolvedTogether) {
  const PoseGraph start = TwoChains();
  const std::vector<bool> held = HeldConstant(start);
  EXPECT_EQ(std::count(held.begin(), held.end(), true), 1);
  EXPECT_TRUE(held[start.VertexIndex(0)]);
  for (SolverKind s : {SolverKind::kCeres, SolverKind::kGaussNewton}) {
    PoseGraph g = start;
    const SolveResult r = s == SolverKind::kCeres ? SolveWithCeres(g) : SolveGaussNewton(g);
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_LT(r.final_chi2, 1e-12);  // consistent measurements
    // Chain 2..3 placed relative to chain 0..1 through the landmarks alone.
    EXPECT_NEAR(g.vertex(2).x[1], 3.0, 1e-6);
    EXPECT_NEAR(g.vertex(3).x[2], -0.2, 1e-6);
    EXPECT_NEAR(g.vertex(11).x[0], 2.0, 1e-6);
  }
}

// Fed in two halves (the landmarks' observations with their poses), with
// either solver, the incremental optimiser reaches the batch optimum.
TEST(LandmarkSolvers, IncrementalReachesTheBatchOptimum) {
  const Simulation sim = WithLandmarks(2, 3);
  const PoseGraph& g = sim.noisy;
  PoseGraph batch = g;
  GaussNewtonOptions go;
  go.function_tolerance = 1e-12;
  ASSERT_TRUE(SolveGaussNewton(batch, go).converged);
  IncrementalOptions io;
  io.ceres.function_tolerance = io.gauss_newton.function_tolerance = 1e-12;
  for (SolverKind s : {SolverKind::kGaussNewton, SolverKind::kCeres}) {
    IncrementalOptimizer opt(2, io);
    for (const Vertex& v : g.vertices())
      if (v.landmark) opt.AddLandmark(v.id, Eigen::Vector3d(v.x[0], v.x[1], 0));
    std::vector<bool> added(g.edges().size(), false);
    const int64_t poses = static_cast<int64_t>(g.vertices().size() - g.CountLandmarks());
    SolveResult r;
    for (int64_t last : {poses / 2, poses - 1}) {
      for (const Vertex& v : g.vertices())
        if (!v.landmark && v.id <= last && !opt.graph().HasVertex(v.id)) opt.AddPose(v.id, ToSE2(v.x));
      for (size_t k = 0; k < g.edges().size(); ++k) {
        const Edge& e = g.edges()[k];
        const int64_t pose_end = e.kind == EdgeKind::kLandmark ? e.from : std::max(e.from, e.to);
        if (added[k] || pose_end > last) continue;
        opt.AddEdge(e);
        added[k] = true;
      }
      r = opt.Optimize(s);
      ASSERT_TRUE(r.usable) << r.message;
    }
    EXPECT_NEAR(r.final_chi2, Chi2(batch), 1e-6 * Chi2(batch));
    EXPECT_EQ(opt.graph().CountEdges(EdgeKind::kLandmark), g.CountEdges(EdgeKind::kLandmark));
  }
}

// A landmark seen once from the held pose, with information Omega: its
// covariance is R Omega^-1 R^T (the world frame), from both paths.
TEST(LandmarkSolvers, LandmarkCovarianceByHand) {
  for (int dim : {2, 3}) {
    PoseGraph g(dim);
    const double c = std::cos(0.7), s = std::sin(0.7);
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    r.topLeftCorner<2, 2>() << c, -s, s, c;
    if (dim == 2) {
      g.AddVertex(0, SE2(1, 2, 0.7));
    } else {
      g.AddVertex(0, SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ())),
                         Eigen::Vector3d(1, 2, 3)));
      g.SetOffset(0, SE3());
    }
    g.AddLandmark(1, Eigen::Vector3d(2, 2, 2));
    Edge e;
    e.kind = EdgeKind::kLandmark;
    e.from = 0;
    e.to = 1;
    e.information.setZero();
    Eigen::Matrix3d info;
    info << 4, 1, 0.5, 1, 3, 0.2, 0.5, 0.2, 2;
    e.information.SetTopLeft(info.topLeftCorner(dim, dim));
    g.AddEdge(e);
    const Eigen::MatrixXd rd = r.topLeftCorner(dim, dim);
    const Eigen::MatrixXd expected =
        rd * Eigen::MatrixXd(info.topLeftCorner(dim, dim)).inverse() * rd.transpose();
    for (SolverKind k : {SolverKind::kCeres, SolverKind::kGaussNewton}) {
      const auto cov = MarginalCovariances(g, {0, 1}, k);
      EXPECT_TRUE(cov[0].isZero());  // the gauge
      ASSERT_EQ(cov[1].rows(), dim);
      EXPECT_LT((cov[1] - expected).norm(), 1e-9 * expected.norm()) << "dim " << dim;
    }
  }
}

// The Gauss-Newton path evaluates edges from the graph (EvaluateEdge)
// instead of keeping a cost function per edge: for every kind of edge, in
// 2D and 3D, it must give the cost function's residual and Jacobians to
// the last bit.
TEST(GraphResiduals, EvaluateAsTheCostFunctionToTheLastBit) {
  for (int dimension : {2, 3}) {
    Simulation sim = WithLandmarks(dimension, 3);
    PoseGraph& g = sim.noisy;
    for (EdgeKind kind : {EdgeKind::kPrior, EdgeKind::kLandmarkPrior}) {
      Edge prior;
      prior.kind = kind;
      for (const Vertex& v : g.vertices())
        if (v.landmark == (kind == EdgeKind::kLandmarkPrior)) prior.from = v.id;
      prior.z = g.vertex(prior.from).x;
      prior.z[0] += 0.3;
      g.AddEdge(prior);
    }
    int kinds[5] = {0, 0, 0, 0, 0};
    for (const Edge& e : g.edges()) {
      ++kinds[static_cast<int>(e.kind)];
      const std::unique_ptr<ceres::CostFunction> cost(MakeCostFunction(g, e));
      const int m = cost->num_residuals();
      ASSERT_EQ(g.ResidualSize(e), m);
      std::vector<const double*> params = {g.vertex(e.from).x.data()};
      if (!e.IsPrior()) params.push_back(g.vertex(e.to).x.data());
      std::vector<std::vector<double>> jc, je;
      std::vector<double*> pc, pe;
      for (size_t p = 0; p < params.size(); ++p) {
        jc.emplace_back(m * cost->parameter_block_sizes()[p], 0.0);
        je.emplace_back(jc.back().size(), 1.0);
      }
      for (size_t p = 0; p < params.size(); ++p) pc.push_back(jc[p].data()), pe.push_back(je[p].data());
      // Without Jacobians both evaluate in doubles, with them in Jets: the
      // two may differ in the last bits, so each is compared with its like.
      std::vector<double> rc(m), rc_only(m), re(m, 1.0), r_only(m, 2.0);
      ASSERT_TRUE(cost->Evaluate(params.data(), rc.data(), pc.data()));
      ASSERT_TRUE(cost->Evaluate(params.data(), rc_only.data(), nullptr));
      ASSERT_TRUE(EvaluateEdge(g, e, params.data(), re.data(), pe.data()));
      ASSERT_TRUE(EvaluateEdge(g, e, params.data(), r_only.data(), nullptr));
      EXPECT_EQ(re, rc);
      EXPECT_EQ(r_only, rc_only);
      EXPECT_EQ(je, jc);
    }
    for (int k = 0; k < 5; ++k) EXPECT_GT(kinds[k], 0) << "no edge of kind " << k;
  }
}

}  // namespace
}  // namespace cairn
