// The whitening square root of a singular information matrix: Omega =
// U^T U, so that |U e|^2 is g2o's e^T Omega e, where Omega has no Cholesky
// factor (a position-only prior, an edge with a zero block).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

#include "cairn/factors/pose_math.h"

namespace cairn::factors {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// A random positive semi-definite matrix of the given rank, not diagonal.
Matrix6d RandomOfRank(std::mt19937& rng, int rank) {
  std::normal_distribution<double> g(0, 1);
  Eigen::Matrix<double, 6, Eigen::Dynamic> b(6, rank);
  for (int i = 0; i < b.size(); ++i) b(i) = g(rng);
  return b * b.transpose();
}

TEST(SqrtInformation, SingularMatricesAreWhitenedExactly) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 1);
  for (int rank = 0; rank < 6; ++rank) {
    const Matrix6d info = RandomOfRank(rng, rank);
    if (rank > 0) ASSERT_NE(info.llt().info() == Eigen::Success &&
                                Matrix6d(info.llt().matrixU()).diagonal().minCoeff() > 0,
                            true);
    const Matrix6d u = SqrtInformation<6>(info);
    EXPECT_TRUE(u.allFinite());
    const double scale = std::max(1.0, info.norm());
    EXPECT_LT((u.transpose() * u - info).norm(), 1e-12 * scale) << "rank " << rank;
    for (int k = 0; k < 5; ++k) {
      Vector6d e;
      for (int i = 0; i < 6; ++i) e[i] = g(rng);
      EXPECT_NEAR((u * e).squaredNorm(), e.dot(info * e), 1e-11 * scale * e.squaredNorm());
    }
  }
}

// A position-only prior: the rotation part of the error weighs nothing.
TEST(SqrtInformation, ZeroBlockGivesNoResidual) {
  Matrix6d info = Matrix6d::Zero();
  info.topLeftCorner<3, 3>() << 4, 1, 0, 1, 3, 0.5, 0, 0.5, 2;
  const Matrix6d u = SqrtInformation<6>(info);
  Vector6d rotation_only = Vector6d::Zero();
  rotation_only.tail<3>() << 0.3, -0.2, 0.1;
  EXPECT_LT((u * rotation_only).norm(), 1e-14);
}

// Positive definite: still the upper Cholesky factor (bit for bit what the
// solvers used before singular matrices were taken).
TEST(SqrtInformation, PositiveDefiniteKeepsTheCholeskyFactor) {
  std::mt19937 rng(5);
  const Matrix6d info = RandomOfRank(rng, 6) + Matrix6d::Identity();
  EXPECT_EQ(SqrtInformation<6>(info), Matrix6d(info.llt().matrixU()));
}

}  // namespace
}  // namespace cairn::factors
