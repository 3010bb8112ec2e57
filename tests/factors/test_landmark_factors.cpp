// The point-landmark factors: their Jacobians against numeric
// differentiation (the pose's manifold on the pose, none on the point), their
// errors against g2o's definitions written with the SE2/SE3 classes, and the
// whitening against the information matrix.
#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "cairn/factors/landmark_factors.h"
#include "cairn/factors/pose_manifold.h"
#include "cairn/graph/geometry.h"
#include "pose_groups.h"

namespace cairn {
namespace {

using testing::Random;
using Cost = std::unique_ptr<ceres::CostFunction>;

constexpr double kPrecision = 1e-6;

// Each block's local Jacobian against central differences, relative to the
// block's largest entry: the checker's own entry-wise test fails on entries
// that are exactly zero (numeric noise of 1e-16 against 0).
::testing::AssertionResult Probe(const ceres::CostFunction& cost,
                                 std::vector<const ceres::Manifold*> manifolds,
                                 std::vector<const double*> blocks) {
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(blocks.data(), kPrecision, &results);
  for (size_t b = 0; b < blocks.size(); ++b) {
    const Eigen::MatrixXd& user = results.local_jacobians[b];
    const Eigen::MatrixXd& num = results.local_numeric_jacobians[b];
    const double scale = std::max(1.0, num.cwiseAbs().maxCoeff());
    if ((user - num).cwiseAbs().maxCoeff() > kPrecision * scale)
      return ::testing::AssertionFailure() << "block " << b << ":\n" << user << "\nnumeric:\n"
                                           << num;
  }
  return ::testing::AssertionSuccess();
}

Eigen::VectorXd Residual(const ceres::CostFunction& cost, std::vector<const double*> blocks) {
  Eigen::VectorXd r(cost.num_residuals());
  EXPECT_TRUE(cost.Evaluate(blocks.data(), r.data(), nullptr));
  return r;
}

SE3 RandomSE3(Random& rng, double spread) {
  Vector6d d;
  for (int i = 0; i < 3; ++i) d[i] = rng.Uniform(-spread, spread);
  for (int i = 3; i < 6; ++i) d[i] = rng.Uniform(-2.0, 2.0);
  return SE3().BoxPlus(d);
}

TEST(LandmarkFactors, SE2PointJacobiansMatchNumericDifferentiation) {
  Random rng(3);
  const auto manifold = factors::MakeSE2Manifold();
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d x(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-3.1, 3.1));
    const Eigen::Vector2d l(rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const Eigen::Vector2d z(rng.Uniform(-2, 2), rng.Uniform(-2, 2));
    const Cost cost(factors::SE2PointFactor::Create(z, rng.Information<2>()));
    EXPECT_TRUE(Probe(*cost, {manifold.get(), nullptr}, {x.data(), l.data()}));
  }
}

TEST(LandmarkFactors, SE3PointJacobiansMatchNumericDifferentiation) {
  Random rng(4);
  const auto manifold = factors::MakeSE3Manifold();
  for (int k = 0; k < 20; ++k) {
    const Vector7d x = RandomSE3(rng, 5).ToVector();
    const SE3 offset = k % 2 ? SE3() : RandomSE3(rng, 0.5);
    const Eigen::Vector3d l(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const Eigen::Vector3d z(rng.Uniform(-2, 2), rng.Uniform(-2, 2), rng.Uniform(-2, 2));
    const Cost cost(factors::SE3PointFactor::Create(z, offset.rotation(), offset.translation(),
                                                    rng.Information<3>()));
    EXPECT_TRUE(Probe(*cost, {manifold.get(), nullptr}, {x.data(), l.data()}));
  }
}

TEST(LandmarkFactors, PointPriorJacobiansMatchNumericDifferentiation) {
  Random rng(5);
  const Eigen::Vector2d l2(1.5, -2), z2(1, 1);
  const Cost c2(factors::PointPriorFactor<2>::Create(z2, rng.Information<2>()));
  EXPECT_TRUE(Probe(*c2, {nullptr}, {l2.data()}));
  const Eigen::Vector3d l3(1.5, -2, 0.5), z3(1, 1, 1);
  const Cost c3(factors::PointPriorFactor<3>::Create(z3, rng.Information<3>()));
  EXPECT_TRUE(Probe(*c3, {nullptr}, {l3.data()}));
}

// g2o's errors: X^-1 l - z (2D), (X O)^-1 l - z (3D), l - z (priors).
TEST(LandmarkFactors, ErrorsAreGraphOptimizersDefinitions) {
  Random rng(6);
  for (int k = 0; k < 10; ++k) {
    const SE2 x(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-3.1, 3.1));
    const Eigen::Vector2d l(rng.Uniform(-5, 5), rng.Uniform(-5, 5)), z(0.3, -0.7);
    const Cost c(factors::SE2PointFactor::Create(z, Eigen::Matrix2d::Identity()));
    const Eigen::Vector3d xv = x.ToVector();
    EXPECT_LT((Residual(*c, {xv.data(), l.data()}) - (x.Inverse() * l - z)).norm(), 1e-12);

    const SE3 x3 = RandomSE3(rng, 5), offset = RandomSE3(rng, 1);
    const Eigen::Vector3d l3(rng.Uniform(-5, 5), rng.Uniform(-5, 5), rng.Uniform(-5, 5));
    const Eigen::Vector3d z3(0.2, -0.4, 1.1);
    const Cost c3(factors::SE3PointFactor::Create(z3, offset.rotation(), offset.translation(),
                                                  Eigen::Matrix3d::Identity()));
    const Vector7d x3v = x3.ToVector();
    const Eigen::Vector3d expected = (x3 * offset).Inverse() * l3 - z3;
    EXPECT_LT((Residual(*c3, {x3v.data(), l3.data()}) - expected).norm(), 1e-12);

    const Cost p3(factors::PointPriorFactor<3>::Create(z3, Eigen::Matrix3d::Identity()));
    EXPECT_LT((Residual(*p3, {l3.data()}) - (l3 - z3)).norm(), 1e-15);
  }
}

// |r|^2 = e^T Omega e for an information matrix with off-diagonal terms.
TEST(LandmarkFactors, WhitenedResidualGivesChiSquared) {
  Random rng(7);
  const SE2 x(1, 2, 0.5);
  const Eigen::Vector2d l(3, -1), z(0.5, 0.5);
  const Eigen::Matrix2d info = rng.Information<2>();
  const Cost white(factors::SE2PointFactor::Create(z, info));
  const Eigen::Vector3d xv = x.ToVector();
  const Eigen::Vector2d e = x.Inverse() * l - z;
  EXPECT_NEAR(Residual(*white, {xv.data(), l.data()}).squaredNorm(), e.dot(info * e),
              1e-10 * e.dot(info * e));
}

}  // namespace
}  // namespace cairn
