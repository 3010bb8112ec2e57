// The factors against numeric differentiation and against g2o's error
// definitions, and the whitening against the information matrix: one typed
// suite over SE(2) and SE(3) (tests/factors/pose_groups.h), then the factors
// inside a whole problem against graph/chi2.
#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/problem.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/graph/geometry.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/factors/pose_manifold.h"
#include "cairn/factors/se2_factors.h"
#include "cairn/factors/se3_factors.h"
#include "pose_groups.h"

namespace cairn {
namespace {

using testing::Random;

// Ceres's checker divides by the larger entry, so it is relative; 1e-6 is
// well above central differences' error and well below any wrong term.
constexpr double kPrecision = 1e-6;

// Probes a cost function with the pose manifold on every block; returns the
// checker's error log on failure so that the test prints it.
::testing::AssertionResult Probe(const ceres::CostFunction& cost, const ceres::Manifold& manifold,
                                 std::vector<const double*> blocks) {
  std::vector<const ceres::Manifold*> manifolds(blocks.size(), &manifold);
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  if (checker.Probe(blocks.data(), kPrecision, &results)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << results.error_log;
}

Eigen::VectorXd Residual(const ceres::CostFunction& cost, std::vector<const double*> blocks) {
  Eigen::VectorXd r(cost.num_residuals());
  EXPECT_TRUE(cost.Evaluate(blocks.data(), r.data(), nullptr));
  return r;
}

// ------------------------------------------- one suite for SE(2) and SE(3)

template <typename G>
class PoseFactors : public ::testing::Test {
 protected:
  using Pose = typename G::Pose;
  using Ambient = typename G::Ambient;
  using Cost = std::unique_ptr<ceres::CostFunction>;

  // Pairs of sampled poses, the second of each pair chosen so that a pair
  // near a half turn is met with either sign (across +-pi in SE(2)).
  std::vector<std::pair<Pose, Pose>> Pairs() const {
    std::vector<std::pair<Pose, Pose>> pairs;
    for (size_t k = 0; k < poses_.size(); ++k)
      pairs.emplace_back(poses_[k], poses_[(k + 1) % poses_.size()]);
    return pairs;
  }
  // Every other call the other parameters of the same pose (the heading a
  // turn away, the quaternion negated): no factor may notice.
  Ambient Params(const Pose& x) {
    const Ambient v = G::ToAmbient(x);
    return (alias_ = !alias_) ? G::Alias(v) : v;
  }
  // The error with the information left out: g2o's e, unwhitened.
  typename G::Tangent BetweenError(const Pose& z, const Ambient& vi, const Ambient& vj) const {
    const Cost cost(G::Between(z, G::Information::Identity()));
    return Residual(*cost, {vi.data(), vj.data()});
  }
  typename G::Tangent PriorError(const Pose& z, const Ambient& v) const {
    const Cost cost(G::Prior(z, G::Information::Identity()));
    return Residual(*cost, {v.data()});
  }

  Random rng_{41};
  const std::unique_ptr<ceres::Manifold> manifold_ = G::Manifold();
  const std::vector<Pose> poses_ = testing::SamplePoses<G>(rng_);
  bool alias_ = false;
};

TYPED_TEST_SUITE(PoseFactors, testing::PoseGroups, testing::PoseGroupNames);

TYPED_TEST(PoseFactors, BetweenJacobianMatchesNumericDifferentiation) {
  for (const auto& [xi, xj] : this->Pairs()) {
    const auto z = xi.Between(xj) * TypeParam::Noise(this->rng_, 0.3);
    const typename TestFixture::Cost cost(
        TypeParam::Between(z, this->rng_.template Information<TypeParam::kTangent>()));
    const auto vi = this->Params(xi), vj = this->Params(xj);
    EXPECT_TRUE(Probe(*cost, *this->manifold_, {vi.data(), vj.data()}))
        << vi.transpose() << "\n" << vj.transpose();
  }
}

TYPED_TEST(PoseFactors, PriorJacobianMatchesNumericDifferentiation) {
  for (const auto& x : this->poses_) {
    const auto z = x * TypeParam::Noise(this->rng_, 0.3);
    const typename TestFixture::Cost cost(
        TypeParam::Prior(z, this->rng_.template Information<TypeParam::kTangent>()));
    const auto v = this->Params(x);
    EXPECT_TRUE(Probe(*cost, *this->manifold_, {v.data()})) << v.transpose();
  }
}

// g2o's error, from the geometry classes instead of the functors' own
// arithmetic: e of Z^-1 (X_i^-1 X_j), wrapped, and zero when Z is exact.
TYPED_TEST(PoseFactors, BetweenErrorIsG2os) {
  for (const auto& [xi, xj] : this->Pairs()) {
    const auto vi = this->Params(xi), vj = this->Params(xj);
    EXPECT_LT(this->BetweenError(xi.Between(xj), vi, vj).norm(), 1e-9);
    const auto z = xi.Between(xj) * TypeParam::Noise(this->rng_, 0.5);
    const auto expected = TypeParam::G2oError(z.Inverse() * xi.Between(xj));
    const auto e = this->BetweenError(z, vi, vj);
    EXPECT_LT((e - expected).norm(), 1e-9) << e.transpose() << " vs " << expected.transpose();
  }
}

TYPED_TEST(PoseFactors, PriorErrorIsG2os) {
  for (const auto& x : this->poses_) {
    const auto v = this->Params(x);
    EXPECT_LT(this->PriorError(x, v).norm(), 1e-10);
    const auto z = x * TypeParam::Noise(this->rng_, 0.5);
    const auto expected = TypeParam::G2oError(z.Inverse() * x);
    const auto e = this->PriorError(z, v);
    EXPECT_LT((e - expected).norm(), 1e-9) << e.transpose() << " vs " << expected.transpose();
  }
}

// The residual is U e with Omega = U^T U, so |r|^2 = e^T Omega e, g2o's
// chi-squared for the edge; the lower factor L (Omega = L L^T) has the same
// |.|^2 only by accident, and the information here is far from diagonal.
template <typename Info, typename Error>
void ExpectWhitenedByUpperFactor(const Info& info, const Error& e, const Eigen::VectorXd& r) {
  const Info upper = info.llt().matrixU();
  const double chi2 = e.dot(info * e);
  EXPECT_LT((r - upper * e).norm(), 1e-9 * (1 + r.norm()));
  EXPECT_NEAR(r.squaredNorm(), chi2, 1e-9 * chi2);
  const Info lower = info.llt().matrixL();
  EXPECT_GT(std::abs((lower * e).squaredNorm() - chi2), 1e-6 * chi2);
}

TYPED_TEST(PoseFactors, BetweenResidualSquaredIsG2osChi2) {
  for (const auto& [xi, xj] : this->Pairs()) {
    const auto z = xi.Between(xj) * TypeParam::Noise(this->rng_, 0.5);
    const auto info = this->rng_.template Information<TypeParam::kTangent>();
    const auto vi = this->Params(xi), vj = this->Params(xj);
    const typename TestFixture::Cost cost(TypeParam::Between(z, info));
    ExpectWhitenedByUpperFactor(info, TypeParam::G2oError(z.Inverse() * xi.Between(xj)),
                                Residual(*cost, {vi.data(), vj.data()}));
  }
}

TYPED_TEST(PoseFactors, PriorResidualSquaredIsG2osChi2) {
  for (const auto& x : this->poses_) {
    const auto z = x * TypeParam::Noise(this->rng_, 0.5);
    const auto info = this->rng_.template Information<TypeParam::kTangent>();
    const auto v = this->Params(x);
    const typename TestFixture::Cost cost(TypeParam::Prior(z, info));
    ExpectWhitenedByUpperFactor(info, TypeParam::G2oError(z.Inverse() * x),
                                Residual(*cost, {v.data()}));
  }
}

// ------------------------------------------------- the problem and chi2

// Twice Ceres's cost over a whole graph is backend/chi2.h's figure: the
// two agree on every edge kind, with non-diagonal information everywhere.
template <typename MakePose, typename MakeNoise>
void CheckCostIsHalfChi2(PoseGraph& graph, Random& rng, MakePose pose, MakeNoise noise) {
  const int n = 12;
  for (int i = 0; i < n; ++i) graph.AddVertex(100 + i, pose(), i == 3);
  auto add = [&](EdgeKind kind, int64_t from, int64_t to) {
    Edge e;
    e.kind = kind;
    e.from = from;
    e.to = to;
    const auto xi = pose();
    e.z = ToParams(kind == EdgeKind::kPrior ? xi : xi * noise());
    Eigen::MatrixXd info = graph.dimension() == 2 ? Eigen::MatrixXd(rng.Information<3>())
                                                  : Eigen::MatrixXd(rng.Information<6>());
    e.information.SetTopLeft(info);
    graph.AddEdge(e);
  };
  for (int i = 0; i + 1 < n; ++i) add(EdgeKind::kOdometry, 100 + i, 101 + i);
  add(EdgeKind::kLoopClosure, 100, 100 + n - 1);
  add(EdgeKind::kLoopClosure, 102, 107);
  add(EdgeKind::kPrior, 104, -1);

  CeresGraphProblem problem(graph, RobustLoss{});
  double cost = 0;
  ceres::Problem::EvaluateOptions options;
  ASSERT_TRUE(problem.problem().Evaluate(options, &cost, nullptr, nullptr, nullptr));
  const double chi2 = Chi2(graph);
  EXPECT_GT(chi2, 1.0);
  EXPECT_NEAR(2 * cost, chi2, 1e-10 * chi2);
}

TEST(FactorsInProblem, TwiceCostIsChi2In2D) {
  using testing::SE2Group;
  Random rng(21);
  PoseGraph graph(2);
  CheckCostIsHalfChi2(
      graph, rng, [&] { return SE2Group::RandomPose(rng); },
      [&] { return SE2Group::Noise(rng, 0.3); });
}

TEST(FactorsInProblem, TwiceCostIsChi2In3D) {
  using testing::SE3Group;
  Random rng(22);
  PoseGraph graph(3);
  CheckCostIsHalfChi2(
      graph, rng, [&] { return SE3Group::RandomPose(rng); },
      [&] { return SE3Group::Noise(rng, 0.3); });
}

}  // namespace
}  // namespace cairn
