// UpdatableCholesky: a factor modified by rank updates and downdates, with
// new fill, stays the factor of the modified matrix; its elimination tree
// reads off its columns.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <random>
#include <vector>

#include "cairn/linear/cholesky_update.h"

namespace cairn {
namespace {

struct Csc {
  std::vector<int> p, i;
  std::vector<double> x;
};

Csc UpperOf(const Eigen::MatrixXd& a) {
  Csc c;
  c.p.push_back(0);
  for (int j = 0; j < a.cols(); ++j) {
    for (int r = 0; r <= j; ++r)
      if (a(r, j) != 0) {
        c.i.push_back(r);
        c.x.push_back(a(r, j));
      }
    c.p.push_back(static_cast<int>(c.i.size()));
  }
  return c;
}

Csc ColumnsOf(const Eigen::MatrixXd& w) {
  Csc c;
  c.p.push_back(0);
  for (int j = 0; j < w.cols(); ++j) {
    for (int r = 0; r < w.rows(); ++r)
      if (w(r, j) != 0) {
        c.i.push_back(r);
        c.x.push_back(w(r, j));
      }
    c.p.push_back(static_cast<int>(c.i.size()));
  }
  return c;
}

// L D L^T read back from the factor.
Eigen::MatrixXd Product(const UpdatableCholesky& f) {
  const int n = f.n();
  Eigen::MatrixXd l = Eigen::MatrixXd::Identity(n, n);
  Eigen::VectorXd d(n);
  for (int j = 0; j < n; ++j) {
    d[j] = f.Pivot(j);
    for (int t = 0; t < f.BelowCount(j); ++t) l(f.BelowRows(j)[t], j) = f.BelowValues(j)[t];
  }
  return l * d.asDiagonal() * l.transpose();
}

// A sparse SPD matrix: a chain plus a few random couplings.
Eigen::MatrixXd Chain(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  for (int j = 0; j + 1 < n; ++j) a(j, j + 1) = a(j + 1, j) = u(rng);
  for (int j = 0; j < n; ++j) a(j, j) = 4 + u(rng);
  return a;
}

Eigen::MatrixXd SparseColumns(int n, int k, int nonzeros, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> row(0, n - 1);
  Eigen::MatrixXd w = Eigen::MatrixXd::Zero(n, k);
  for (int c = 0; c < k; ++c)
    for (int t = 0; t < nonzeros; ++t) w(row(rng), c) = u(rng);
  return w;
}

TEST(CholeskyUpdate, UpdatesAndDowndatesWithNewFillStayExact) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    const int n = 40;
    Eigen::MatrixXd a = Chain(n, rng);
    UpdatableCholesky f;
    const Csc ca = UpperOf(a);
    ASSERT_TRUE(f.Factorize(n, ca.p, ca.i, ca.x));
    EXPECT_LT((Product(f) - a).cwiseAbs().maxCoeff(), 1e-12);
    for (int round = 0; round < 10; ++round) {
      // Couplings far apart in the order: fill the factor did not have.
      const Eigen::MatrixXd w = SparseColumns(n, 1 + round % 7, 3, rng);
      const Csc cw = ColumnsOf(w);
      ASSERT_TRUE(f.Modify(true, static_cast<int>(w.cols()), cw.p, cw.i, cw.x));
      a += w * w.transpose();
      EXPECT_LT((Product(f) - a).cwiseAbs().maxCoeff(), 1e-10) << "seed " << seed;
      // Taking half of it out again stays positive definite.
      const Eigen::MatrixXd half = w * std::sqrt(0.5);
      const Csc ch = ColumnsOf(half);
      ASSERT_TRUE(f.Modify(false, static_cast<int>(w.cols()), ch.p, ch.i, ch.x));
      a -= half * half.transpose();
      EXPECT_LT((Product(f) - a).cwiseAbs().maxCoeff(), 1e-10) << "seed " << seed;
    }
  }
}

TEST(CholeskyUpdate, ParentIsTheFirstRowBelowTheDiagonal) {
  std::mt19937 rng(7);
  const int n = 30;
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(n, n) * 3;
  a(2, 9) = a(9, 2) = 0.5;
  UpdatableCholesky f;
  const Csc ca = UpperOf(a);
  ASSERT_TRUE(f.Factorize(n, ca.p, ca.i, ca.x));
  EXPECT_EQ(f.Parent(2), 9);
  EXPECT_EQ(f.Parent(5), -1);
  // Coupling 2 with 4 puts 4 between 2 and 9: 2 -> 4 -> 9.
  Eigen::MatrixXd w = Eigen::MatrixXd::Zero(n, 1);
  w(2, 0) = 1;
  w(4, 0) = 1;
  const Csc cw = ColumnsOf(w);
  ASSERT_TRUE(f.Modify(true, 1, cw.p, cw.i, cw.x));
  EXPECT_EQ(f.Parent(2), 4);
  EXPECT_EQ(f.Parent(4), 9);
  (void)rng;
}

TEST(CholeskyUpdate, RefusesAnIndefiniteMatrix) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(4, 4);
  a(3, 3) = -1;
  UpdatableCholesky f;
  const Csc ca = UpperOf(a);
  EXPECT_FALSE(f.Factorize(4, ca.p, ca.i, ca.x));
}

}  // namespace
}  // namespace cairn
