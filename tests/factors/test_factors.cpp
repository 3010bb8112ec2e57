// The factors against numeric differentiation and against g2o's error
// definitions, and the whitening against the information matrix.
#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/problem.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/graph/geometry.h"
#include "cairn/graph/pose_graph.h"
#include "cairn/factors/pose_manifold.h"
#include "cairn/factors/se2_factors.h"
#include "cairn/factors/se3_factors.h"
#include "test_util.h"

namespace cairn {
namespace {

using factors::Matrix6d;

// Ceres's checker divides by the larger entry, so it is relative; 1e-6 is
// well above central differences' error and well below any wrong term.
constexpr double kPrecision = 1e-6;

class Random {
 public:
  explicit Random(unsigned seed) : gen_(seed) {}
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(gen_); }
  double Normal(double sigma) { return std::normal_distribution<>(0, sigma)(gen_); }

  SE2 Pose2(double theta) { return SE2(Uniform(-10, 10), Uniform(-10, 10), theta); }
  SE2 Pose2() { return Pose2(Uniform(-M_PI, M_PI)); }
  SE3 Pose3(const Eigen::Quaterniond& q) {
    return SE3(q, Eigen::Vector3d(Uniform(-10, 10), Uniform(-10, 10), Uniform(-10, 10)));
  }
  SE3 Pose3() { return Pose3(Quaternion()); }
  Eigen::Quaterniond Quaternion() {
    Eigen::Quaterniond q(Normal(1), Normal(1), Normal(1), Normal(1));
    return q.normalized();
  }
  // A rotation by pi - eps about a random axis: w close to zero, so the
  // quaternion's sign is about to flip.
  Eigen::Quaterniond NearHalfTurn(double eps) {
    const Eigen::Vector3d axis =
        Eigen::Vector3d(Normal(1), Normal(1), Normal(1)).normalized();
    return Eigen::Quaterniond(Eigen::AngleAxisd(M_PI - eps, axis));
  }
  // Symmetric positive definite with off-diagonal terms of the same order
  // as the diagonal, so that the lower and upper Cholesky factors differ.
  template <int N>
  Eigen::Matrix<double, N, N> Information() {
    Eigen::Matrix<double, N, N> b;
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) b(i, j) = Normal(1);
    return b * b.transpose() + 0.5 * Eigen::Matrix<double, N, N>::Identity();
  }
  SE2 Noise2(double s) { return SE2(Normal(s), Normal(s), Normal(s)); }
  SE3 Noise3(double s) {
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = Normal(s);
    return SE3().BoxPlus(d);
  }

 private:
  std::mt19937 gen_;
};

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

// ---------------------------------------------------------------- SE(2)

// g2o's EDGE_SE2 error, written with the geometry classes instead of the
// functor's expanded trigonometry.
Eigen::Vector3d G2oError2(const SE2& xi, const SE2& xj, const SE2& z) {
  const SE2 e = z.Inverse() * (xi.Inverse() * xj);
  return e.ToVector();
}

TEST(SE2Factors, BetweenJacobianAtRandomPoses) {
  Random rng(1);
  const auto manifold = factors::MakeSE2Manifold();
  for (int k = 0; k < 50; ++k) {
    const SE2 xi = rng.Pose2(), xj = rng.Pose2();
    const SE2 z = xi.Between(xj) * rng.Noise2(0.3);
    std::unique_ptr<ceres::CostFunction> cost(
        factors::SE2BetweenFactor::Create(z.ToVector(), rng.Information<3>()));
    const Eigen::Vector3d vi = xi.ToVector(), vj = xj.ToVector();
    EXPECT_TRUE(Probe(*cost, *manifold, {vi.data(), vj.data()})) << "pose pair " << k;
  }
}

TEST(SE2Factors, BetweenJacobianAcrossPlusMinusPi) {
  Random rng(2);
  const auto manifold = factors::MakeSE2Manifold();
  const double eps[] = {1e-9, 1e-4, 1e-2};
  for (double e : eps) {
    // One pose just below +pi, the other just above -pi: the raw difference
    // of angles is near -2 pi and only the wrap makes it small.
    for (int sign : {1, -1}) {
      const SE2 xi = rng.Pose2(sign * (M_PI - e)), xj = rng.Pose2(-sign * (M_PI - e));
      const SE2 z = xi.Between(xj) * rng.Noise2(0.05);
      std::unique_ptr<ceres::CostFunction> cost(
          factors::SE2BetweenFactor::Create(z.ToVector(), rng.Information<3>()));
      const Eigen::Vector3d vi(xi.x(), xi.y(), sign * (M_PI - e));
      const Eigen::Vector3d vj(xj.x(), xj.y(), -sign * (M_PI - e));
      EXPECT_TRUE(Probe(*cost, *manifold, {vi.data(), vj.data()})) << "eps " << e;
      // The residual is g2o's, wrapped, not a difference near 2 pi.
      const Eigen::Vector3d r = Residual(*cost, {vi.data(), vj.data()});
      EXPECT_LT(r.norm(), 10.0);
    }
  }
}

TEST(SE2Factors, PriorJacobianAtRandomPosesAndNearPi) {
  Random rng(3);
  const auto manifold = factors::MakeSE2Manifold();
  for (int k = 0; k < 40; ++k) {
    const double theta = k < 20 ? rng.Uniform(-M_PI, M_PI) : (k % 2 ? 1 : -1) * (M_PI - 1e-7);
    const SE2 x = rng.Pose2(theta);
    const SE2 z = x * rng.Noise2(0.3);
    std::unique_ptr<ceres::CostFunction> cost(
        factors::SE2PriorFactor::Create(z.ToVector(), rng.Information<3>()));
    const Eigen::Vector3d v(x.x(), x.y(), theta);
    EXPECT_TRUE(Probe(*cost, *manifold, {v.data()})) << "pose " << k;
  }
}

TEST(SE2Factors, ErrorIsG2osAndZeroWhenExact) {
  Random rng(4);
  for (int k = 0; k < 50; ++k) {
    const SE2 xi = rng.Pose2(), xj = rng.Pose2();
    const Eigen::Vector3d vi = xi.ToVector(), vj = xj.ToVector();
    const SE2 exact = xi.Between(xj);
    const Eigen::Matrix3d info = rng.Information<3>();
    std::unique_ptr<ceres::CostFunction> cost(
        factors::SE2BetweenFactor::Create(exact.ToVector(), info));
    EXPECT_LT(Residual(*cost, {vi.data(), vj.data()}).norm(), 1e-9);
    std::unique_ptr<ceres::CostFunction> prior(factors::SE2PriorFactor::Create(vi, info));
    EXPECT_LT(Residual(*prior, {vi.data()}).norm(), 1e-12);

    const SE2 z = exact * rng.Noise2(0.5);
    Eigen::Vector3d e;
    factors::SE2BetweenFactor(z.ToVector(), Eigen::Matrix3d::Identity())(vi.data(), vj.data(),
                                                                         e.data());
    const Eigen::Vector3d expected = G2oError2(xi, xj, z);
    EXPECT_LT((e - expected).norm(), 1e-9) << e.transpose() << " vs " << expected.transpose();
  }
}

TEST(SE2Factors, SquaredResidualIsChi2WithNonDiagonalInformation) {
  Random rng(5);
  for (int k = 0; k < 20; ++k) {
    const SE2 xi = rng.Pose2(), xj = rng.Pose2();
    const SE2 z = xi.Between(xj) * rng.Noise2(0.5);
    const Eigen::Matrix3d info = rng.Information<3>();
    const Eigen::Vector3d vi = xi.ToVector(), vj = xj.ToVector();
    const Eigen::Vector3d e = G2oError2(xi, xj, z);
    std::unique_ptr<ceres::CostFunction> cost(
        factors::SE2BetweenFactor::Create(z.ToVector(), info));
    const double chi2 = e.dot(info * e);
    EXPECT_NEAR(Residual(*cost, {vi.data(), vj.data()}).squaredNorm(), chi2, 1e-9 * chi2);
    // The lower factor would be wrong here: the test can tell them apart.
    const Eigen::Matrix3d lower = info.llt().matrixL();
    EXPECT_GT(std::abs((lower * e).squaredNorm() - chi2), 1e-6 * chi2);
  }
}

// ---------------------------------------------------------------- SE(3)

Vector6d G2oError3(const SE3& xi, const SE3& xj, const SE3& z) {
  const SE3 e = z.Inverse() * (xi.Inverse() * xj);
  Eigen::Quaterniond q = e.rotation();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  Vector6d out;
  out << e.translation(), q.vec();
  return out;
}

std::unique_ptr<ceres::CostFunction> Between3(const SE3& z, const Matrix6d& info) {
  return std::unique_ptr<ceres::CostFunction>(
      factors::SE3BetweenFactor::Create(z.rotation(), z.translation(), info));
}

TEST(SE3Factors, BetweenJacobianAtRandomPoses) {
  Random rng(11);
  const auto manifold = factors::MakeSE3Manifold();
  for (int k = 0; k < 50; ++k) {
    const SE3 xi = rng.Pose3(), xj = rng.Pose3();
    const SE3 z = xi.Between(xj) * rng.Noise3(0.3);
    const auto cost = Between3(z, rng.Information<6>());
    const Vector7d vi = xi.ToVector(), vj = xj.ToVector();
    EXPECT_TRUE(Probe(*cost, *manifold, {vi.data(), vj.data()})) << "pose pair " << k;
  }
}

TEST(SE3Factors, BetweenJacobianNearHalfTurns) {
  Random rng(12);
  const auto manifold = factors::MakeSE3Manifold();
  for (double eps : {1e-9, 1e-6, 1e-3}) {
    for (int k = 0; k < 6; ++k) {
      const SE3 xi = rng.Pose3(rng.NearHalfTurn(eps));
      const SE3 xj = rng.Pose3(rng.NearHalfTurn(eps));
      const SE3 z = xi.Between(xj) * rng.Noise3(0.05);
      const auto cost = Between3(z, rng.Information<6>());
      Vector7d vi = xi.ToVector(), vj = xj.ToVector();
      // Store one quaternion with the other sign (w < 0 when it was >= 0):
      // the same rotation, and the residual must not notice.
      if (k % 2) vj.tail<4>() = -vj.tail<4>();
      EXPECT_TRUE(Probe(*cost, *manifold, {vi.data(), vj.data()})) << "eps " << eps << " k " << k;
      const Vector6d expected = G2oError3(xi, xj, z);
      Vector6d e;
      factors::SE3BetweenFactor(z.rotation(), z.translation(), Matrix6d::Identity())(
          vi.data(), vj.data(), e.data());
      EXPECT_LT((e - expected).norm(), 1e-9);
    }
  }
}

TEST(SE3Factors, PriorJacobianAtRandomPosesAndNearHalfTurns) {
  Random rng(13);
  const auto manifold = factors::MakeSE3Manifold();
  for (int k = 0; k < 40; ++k) {
    const SE3 x = rng.Pose3(k < 20 ? rng.Quaternion() : rng.NearHalfTurn(k % 3 ? 1e-8 : 1e-4));
    const SE3 z = x * rng.Noise3(0.3);
    std::unique_ptr<ceres::CostFunction> cost(
        factors::SE3PriorFactor::Create(z.rotation(), z.translation(), rng.Information<6>()));
    Vector7d v = x.ToVector();
    if (k % 2) v.tail<4>() = -v.tail<4>();
    EXPECT_TRUE(Probe(*cost, *manifold, {v.data()})) << "pose " << k;
  }
}

TEST(SE3Factors, ErrorIsG2osAndZeroWhenExact) {
  Random rng(14);
  for (int k = 0; k < 50; ++k) {
    const SE3 xi = rng.Pose3(k % 2 ? rng.NearHalfTurn(1e-7) : rng.Quaternion());
    const SE3 xj = rng.Pose3();
    const Vector7d vi = xi.ToVector(), vj = xj.ToVector();
    const SE3 exact = xi.Between(xj);
    const Matrix6d info = rng.Information<6>();
    EXPECT_LT(Residual(*Between3(exact, info), {vi.data(), vj.data()}).norm(), 1e-8);
    std::unique_ptr<ceres::CostFunction> prior(
        factors::SE3PriorFactor::Create(xi.rotation(), xi.translation(), info));
    EXPECT_LT(Residual(*prior, {vi.data()}).norm(), 1e-10);

    const SE3 z = exact * rng.Noise3(0.5);
    Vector6d e;
    factors::SE3BetweenFactor(z.rotation(), z.translation(), Matrix6d::Identity())(
        vi.data(), vj.data(), e.data());
    EXPECT_LT((e - G2oError3(xi, xj, z)).norm(), 1e-9);
  }
}

TEST(SE3Factors, SquaredResidualIsChi2WithNonDiagonalInformation) {
  Random rng(15);
  for (int k = 0; k < 20; ++k) {
    const SE3 xi = rng.Pose3(), xj = rng.Pose3();
    const SE3 z = xi.Between(xj) * rng.Noise3(0.5);
    const Matrix6d info = rng.Information<6>();
    const Vector7d vi = xi.ToVector(), vj = xj.ToVector();
    const Vector6d e = G2oError3(xi, xj, z);
    const double chi2 = e.dot(info * e);
    EXPECT_NEAR(Residual(*Between3(z, info), {vi.data(), vj.data()}).squaredNorm(), chi2,
                1e-9 * chi2);
    const Matrix6d lower = info.llt().matrixL();
    EXPECT_GT(std::abs((lower * e).squaredNorm() - chi2), 1e-6 * chi2);
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
    e.information.setIdentity();
    e.information.topLeftCorner(info.rows(), info.cols()) = info;
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
  Random rng(21);
  PoseGraph graph(2);
  CheckCostIsHalfChi2(
      graph, rng, [&] { return rng.Pose2(); }, [&] { return rng.Noise2(0.3); });
}

TEST(FactorsInProblem, TwiceCostIsChi2In3D) {
  Random rng(22);
  PoseGraph graph(3);
  CheckCostIsHalfChi2(
      graph, rng, [&] { return rng.Pose3(); }, [&] { return rng.Noise3(0.3); });
}

}  // namespace
}  // namespace cairn
