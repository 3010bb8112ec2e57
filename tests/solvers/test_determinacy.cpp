// Singular information in a solve: position-only priors (a GPS fix), edges
// with a zero block. Both solvers reach the true poses when the graph
// determines them, hold a rotation gauge where only positions are fixed,
// and otherwise refuse naming the vertex and the direction nothing fixes.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/covariance.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_gauss_newton.h"

namespace cairn {
namespace {

// Eight poses on a loop (planar ones in the plane, spatial ones climbing
// and tilting), measured without noise: the optimum is the truth itself.
std::vector<PoseParams> Truth(int dimension) {
  std::vector<PoseParams> out;
  for (int i = 0; i < 8; ++i) {
    const double a = 2 * M_PI * i / 8;
    const double x = 4 * std::cos(a), y = 3 * std::sin(a);
    if (dimension == 2) {
      out.push_back(ToParams(SE2(x, y, a + 0.3)));
    } else {
      const Eigen::Quaterniond q(Eigen::AngleAxisd(a + 0.3, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.2 * i, Eigen::Vector3d::UnitX()));
      out.push_back(ToParams(SE3(q, Eigen::Vector3d(x, y, 0.5 * i))));
    }
  }
  return out;
}

// Weights for (translation, rotation): zero leaves that block out.
Matrix6d Information(int dimension, double translation, double rotation) {
  Matrix6d info = Matrix6d::Zero();
  const int t = dimension == 2 ? 2 : 3, r = dimension == 2 ? 1 : 3;
  info.topLeftCorner(t, t) = translation * Eigen::MatrixXd::Identity(t, t);
  info.block(t, t, r, r) = rotation * Eigen::MatrixXd::Identity(r, r);
  if (translation > 0) info(0, 1) = info(1, 0) = 0.3 * translation;  // not diagonal
  return info;
}

class Builder {
 public:
  explicit Builder(int dimension) : dim_(dimension), graph_(dimension), truth_(Truth(dimension)) {
    // The start: each pose moved off the truth, differently.
    for (size_t i = 0; i < truth_.size(); ++i) {
      PoseParams x = truth_[i];
      if (dim_ == 2) {
        x = ToParams(ToSE2(x) * SE2(0.2, -0.1 * i, 0.05));
      } else {
        Vector6d d;
        d << 0.2, -0.1, 0.05 * i, 0.04, -0.03, 0.05;
        x = ToParams(ToSE3(x).BoxPlus(d));
      }
      graph_.AddVertex(static_cast<int64_t>(i), x);
    }
  }
  void Between(int64_t i, int64_t j, double translation = 100, double rotation = 400) {
    Edge e;
    e.kind = KindForBetween(i, j);
    e.from = i;
    e.to = j;
    e.z = dim_ == 2 ? ToParams(ToSE2(truth_[i]).Between(ToSE2(truth_[j])))
                    : ToParams(ToSE3(truth_[i]).Between(ToSE3(truth_[j])));
    e.information = Information(dim_, translation, rotation);
    graph_.AddEdge(e);
  }
  void Odometry() {
    for (int64_t i = 0; i + 1 < static_cast<int64_t>(truth_.size()); ++i) Between(i, i + 1);
  }
  // A position-only prior at the true position (rotation weight zero).
  void Gps(int64_t i, double rotation = 0) {
    Edge e;
    e.kind = EdgeKind::kPrior;
    e.from = i;
    e.z = truth_[i];
    e.information = Information(dim_, 10, rotation);
    graph_.AddEdge(e);
  }
  PoseGraph& graph() { return graph_; }
  const std::vector<PoseParams>& truth() const { return truth_; }

 private:
  int dim_;
  PoseGraph graph_;
  std::vector<PoseParams> truth_;
};

// Largest translation and rotation-angle error against `truth` after
// expressing both relative to pose `ref` (ref < 0: absolute).
std::pair<double, double> Error(const PoseGraph& g, const std::vector<PoseParams>& truth,
                                int ref = -1) {
  double dt = 0, dr = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const PoseParams& x = g.vertices()[i].x;
    if (g.dimension() == 2) {
      SE2 a = ToSE2(x), b = ToSE2(truth[i]);
      if (ref >= 0) {
        a = ToSE2(g.vertices()[ref].x).Between(a);
        b = ToSE2(truth[ref]).Between(b);
      }
      const SE2 d = b.Between(a);
      dt = std::max(dt, d.translation().norm());
      dr = std::max(dr, std::abs(d.theta()));
    } else {
      SE3 a = ToSE3(x), b = ToSE3(truth[i]);
      if (ref >= 0) {
        a = ToSE3(g.vertices()[ref].x).Between(a);
        b = ToSE3(truth[ref]).Between(b);
      }
      const SE3 d = b.Between(a);
      dt = std::max(dt, d.translation().norm());
      dr = std::max(dr, Eigen::AngleAxisd(d.rotation()).angle());
    }
  }
  return {dt, dr};
}

// Both solvers on copies of `graph`: each converges to chi2 ~ 0.
std::vector<PoseGraph> SolveBoth(const PoseGraph& graph) {
  std::vector<PoseGraph> out{graph, graph};
  const SolveResult c = SolveWithCeres(out[0]);
  const SolveResult g = SolveGaussNewton(out[1]);
  for (const SolveResult* r : {&c, &g}) {
    EXPECT_TRUE(r->usable) << r->solver << ": " << r->message;
    EXPECT_TRUE(r->converged) << r->solver << ": " << r->message;
    EXPECT_LT(r->final_chi2, 1e-12 * std::max(1.0, r->initial_chi2)) << r->solver;
    EXPECT_GT(r->initial_chi2, 1.0) << r->solver;  // the start was off
  }
  return out;
}

void ExpectTruth(const PoseGraph& graph, const std::vector<PoseParams>& truth) {
  for (const PoseGraph& g : SolveBoth(graph)) {
    const auto [dt, dr] = Error(g, truth);
    EXPECT_LT(dt, 1e-6);
    EXPECT_LT(dr, 1e-6);
  }
}

void ExpectRefused(const PoseGraph& graph, const std::string& what) {
  PoseGraph c = graph, g = graph;
  for (const SolveResult& r : {SolveWithCeres(c), SolveGaussNewton(g)}) {
    EXPECT_FALSE(r.usable) << r.solver;
    EXPECT_EQ(r.termination, "failure") << r.solver;
    EXPECT_NE(r.message.find(what), std::string::npos) << r.solver << ": " << r.message;
    EXPECT_TRUE(std::isfinite(r.final_chi2)) << r.solver;
  }
  // Nothing moved, nothing NaN.
  for (const PoseGraph* p : {&c, &g})
    for (size_t i = 0; i < graph.vertices().size(); ++i)
      EXPECT_EQ(p->vertices()[i].x, graph.vertices()[i].x);
}

class Determinacy : public ::testing::TestWithParam<int> {};

// GPS fixes at three places that are not on a line fix the whole graph:
// nothing is held, and the solution is the truth.
TEST_P(Determinacy, PositionOnlyPriorsDetermineTheGraph) {
  Builder b(GetParam());
  b.Odometry();
  b.Between(7, 0);
  for (int64_t i : {0, 2, 5}) b.Gps(i);
  const GraphGauge gauge = ComputeGauge(b.graph());
  EXPECT_TRUE(gauge.undetermined.empty()) << gauge.undetermined;
  for (size_t i = 0; i < gauge.held.size(); ++i) {
    EXPECT_FALSE(gauge.held[i]);
    EXPECT_FALSE(gauge.rotation_held[i]);
  }
  ExpectTruth(b.graph(), b.truth());
}

// One GPS fix: the position is fixed, the rotation about it is not; the
// component's rotation gauge is held at the prior's vertex, which ends at
// its measured position with its starting rotation, the rest right
// relative to it.
TEST_P(Determinacy, OnePositionOnlyPriorHoldsTheRotationGauge) {
  Builder b(GetParam());
  b.Odometry();
  b.Gps(3);
  const GraphGauge gauge = ComputeGauge(b.graph());
  EXPECT_TRUE(gauge.rotation_held[3]);
  for (size_t i = 0; i < gauge.held.size(); ++i) {
    EXPECT_FALSE(gauge.held[i]);
    if (i != 3) EXPECT_FALSE(gauge.rotation_held[i]);
  }
  const PoseParams start = b.graph().vertex(3).x;
  for (const PoseGraph& g : SolveBoth(b.graph())) {
    const auto [dt, dr] = Error(g, b.truth(), 3);
    EXPECT_LT(dt, 1e-6);
    EXPECT_LT(dr, 1e-6);
    const PoseParams& x = g.vertex(3).x;
    for (int k = 0; k < 3; ++k)
      if (k < GetParam()) EXPECT_NEAR(x[k], b.truth()[3][k], 1e-6);
    for (int k = GetParam(); k < g.ParameterSize(); ++k) EXPECT_NEAR(x[k], start[k], 1e-12);
  }
}

// Covariances see the same gauge (through the incremental optimizer): the
// prior's vertex has only its translation's, the fix's own inverse (in the
// pose's frame, which is turned from the fix's: the same eigenvalues);
// every other pose its full one.
TEST_P(Determinacy, CovariancesUnderARotationGauge) {
  Builder b(GetParam());
  b.Odometry();
  b.Gps(3);
  PoseGraph g = b.graph();
  ASSERT_TRUE(SolveGaussNewton(g).usable);
  const int t = GetParam();
  for (SolverKind kind : {SolverKind::kCeres, SolverKind::kGaussNewton}) {
    const auto cov = MarginalCovariances(g, {3, 6}, kind);
    ASSERT_EQ(cov.size(), 2u);
    ASSERT_EQ(cov[0].rows(), t);
    const Eigen::MatrixXd prior_cov = Information(GetParam(), 10, 0).topLeftCorner(t, t).inverse();
    const Eigen::VectorXd expected = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(prior_cov).eigenvalues();
    const Eigen::VectorXd got = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(cov[0]).eigenvalues();
    EXPECT_LT((got - expected).norm(), 1e-6 * expected.norm()) << cov[0];
    ASSERT_EQ(cov[1].rows(), g.TangentSize());
    EXPECT_TRUE(cov[1].allFinite());
    EXPECT_GT(cov[1].diagonal().minCoeff(), 0);
    EXPECT_LT(cov[1].diagonal().maxCoeff(), 10);
  }
}

// A full prior anchors its component: no vertex is held besides.
TEST_P(Determinacy, FullPriorHoldsNothing) {
  Builder b(GetParam());
  b.Odometry();
  b.Gps(4, /*rotation=*/50);
  const GraphGauge gauge = ComputeGauge(b.graph());
  for (size_t i = 0; i < gauge.held.size(); ++i) {
    EXPECT_FALSE(gauge.held[i]);
    EXPECT_FALSE(gauge.rotation_held[i]);
  }
  ExpectTruth(b.graph(), b.truth());
}

// Pose 7 is reached only by edges that say nothing of rotation, all from
// it: the bearings of poses 1 and 4 seen from it fix its heading in 2D; in
// 3D it could still turn about the line through them (FindUndetermined
// says so), and a third, pose 6, fixes that.
TEST_P(Determinacy, BetweenEdgesWithAZeroBlock) {
  Builder b(GetParam());
  for (int64_t i = 0; i < 6; ++i) b.Between(i, i + 1);
  b.Between(7, 1, 100, 0);
  b.Between(7, 4, 100, 0);
  if (GetParam() == 3) {
    const auto why = FindUndetermined(b.graph(), ComputeGauge(b.graph()));
    ASSERT_TRUE(why.has_value());
    EXPECT_NE(why->find("vertex 7: "), std::string::npos) << *why;
    b.Between(7, 6, 100, 0);
  }
  b.Between(0, 4, 0, 400);  // and one that says nothing of translation
  b.graph().vertex(0).fixed = true;
  b.graph().vertex(0).x = b.truth()[0];
  ExpectTruth(b.graph(), b.truth());
}

// Pose 7 held by a GPS fix and an edge towards it without rotation: its
// heading appears in no residual.
TEST_P(Determinacy, AFreeRotationIsNamed) {
  Builder b(GetParam());
  for (int64_t i = 0; i < 6; ++i) b.Between(i, i + 1);
  b.Gps(0, 50);
  b.Between(6, 7, 100, 0);
  b.Gps(7);
  ExpectRefused(b.graph(), GetParam() == 2 ? "vertex 7: rotation about z is not constrained by any edge"
                                           : "is not constrained by any edge");
  ExpectRefused(b.graph(), "vertex 7: rotation about");
}

TEST_P(Determinacy, AGaugeOnlyPartlyFixedIsNamed) {
  Builder b(GetParam());
  b.Odometry();
  if (GetParam() == 3) {
    // Two fixes: the rotation about the line through them is free.
    b.Gps(0);
    b.Gps(5);
    ExpectRefused(b.graph(), "vertex 0 and its component: rotation about");
  } else {
    // A fix of x alone: translation along y (and the rotation) free.
    Edge e;
    e.kind = EdgeKind::kPrior;
    e.from = 2;
    e.z = b.truth()[2];
    e.information = Matrix6d::Zero();
    e.information(0, 0) = 10;
    b.graph().AddEdge(e);
    ExpectRefused(b.graph(), "vertex 2 and its component:");
  }
  ExpectRefused(b.graph(), "not fixed by its priors");
}

INSTANTIATE_TEST_SUITE_P(Dimensions, Determinacy, ::testing::Values(2, 3),
                         [](const auto& info) { return std::to_string(info.param) + "D"; });

}  // namespace
}  // namespace cairn
