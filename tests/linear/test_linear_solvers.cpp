// The two other ways to solve the Gauss-Newton step: conjugate gradients
// (both preconditioners) on H, and sparse QR on the Jacobian itself, each
// against a dense solve of the same system.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "cairn/linear/conjugate_gradients.h"
#include "cairn/linear/sparse_qr.h"

namespace cairn {
namespace {

// H = sum over edges of J_e^T J_e, as a pose graph's: 3x3 blocks, a chain
// and some loop closures, one block held by a prior. Upper triangle in
// compressed columns, full blocks, rows sorted.
struct GraphMatrix {
  Eigen::MatrixXd h;
  std::vector<int> col_ptr, rows;
};

GraphMatrix MakeGraphMatrix(int blocks, int loops, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, blocks - 1);
  std::vector<std::pair<int, int>> edges;
  for (int i = 0; i + 1 < blocks; ++i) edges.push_back({i, i + 1});
  for (int k = 0; k < loops; ++k) {
    int i = pick(rng), j = pick(rng);
    if (i == j) continue;
    edges.push_back({std::min(i, j), std::max(i, j)});
  }
  const int n = 3 * blocks;
  GraphMatrix g;
  g.h = Eigen::MatrixXd::Zero(n, n);
  std::vector<std::vector<bool>> coupled(blocks, std::vector<bool>(blocks, false));
  for (const auto& [i, j] : edges) {
    // A between-factor's Jacobian: -R and I, with a random whitening.
    Eigen::MatrixXd je(3, n);
    je.setZero();
    const Eigen::Matrix3d w = Eigen::Matrix3d::Random() + 3 * Eigen::Matrix3d::Identity();
    je.block<3, 3>(0, 3 * i) = -w * Eigen::Matrix3d::Random();
    je.block<3, 3>(0, 3 * j) = w;
    g.h += je.transpose() * je;
    coupled[i][j] = true;
  }
  g.h.topLeftCorner<3, 3>() += Eigen::Matrix3d::Identity();  // the prior: the gauge
  g.col_ptr.push_back(0);
  for (int bj = 0; bj < blocks; ++bj)
    for (int c = 0; c < 3; ++c) {
      for (int bi = 0; bi < bj; ++bi)
        if (coupled[bi][bj])
          for (int r = 0; r < 3; ++r) g.rows.push_back(3 * bi + r);
      for (int r = 0; r <= c; ++r) g.rows.push_back(3 * bj + r);
      g.col_ptr.push_back(static_cast<int>(g.rows.size()));
    }
  return g;
}

TEST(ConjugateGradients, BothPreconditionersSolveAPoseGraphsNormalEquations) {
  for (Preconditioner pre : {Preconditioner::kBlockJacobi, Preconditioner::kSpanningTree}) {
    for (unsigned seed : {1u, 2u, 3u}) {
      const GraphMatrix g = MakeGraphMatrix(120, 60, seed);
      ConjugateGradientsOptions o;
      o.preconditioner = pre;
      auto cg = CreateConjugateGradients(o);
      const int n = static_cast<int>(g.h.rows());
      cg->Analyze(n, g.col_ptr, g.rows, std::vector<int>(n / 3, 3));
      for (int j = 0; j < n; ++j)
        for (int k = g.col_ptr[j]; k < g.col_ptr[j + 1]; ++k) cg->values()[k] = g.h(g.rows[k], j);
      ASSERT_TRUE(cg->Factorize());
      const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1, 2);
      Eigen::VectorXd x(n);
      cg->Solve(b.data(), x.data());
      const Eigen::VectorXd exact = g.h.ldlt().solve(b);
      // CG stops on the quadratic model (what a Gauss-Newton step's decrease
      // is): it must be within 1e-10 of the exact one; the step itself then
      // within about the square root of that times the condition number.
      auto model = [&](const Eigen::VectorXd& v) { return 0.5 * v.dot(g.h * v) - b.dot(v); };
      EXPECT_NEAR(model(x) / model(exact), 1.0, 1e-10) << cg->Method() << ", seed " << seed;
      EXPECT_LT((x - exact).norm(), 1e-4 * exact.norm()) << cg->Method() << ", seed " << seed;
      const bool tree = cg->Method().find("spanning-tree") != std::string::npos;
      EXPECT_EQ(tree, pre == Preconditioner::kSpanningTree) << cg->Method();
    }
  }
}

TEST(ConjugateGradients, RefusesAnIndefiniteMatrix) {
  GraphMatrix g = MakeGraphMatrix(30, 10, 4);
  const int n = static_cast<int>(g.h.rows());
  g.h(40, 40) = -5;  // a diagonal block no longer positive definite
  auto cg = CreateConjugateGradients();
  cg->Analyze(n, g.col_ptr, g.rows, std::vector<int>(n / 3, 3));
  for (int j = 0; j < n; ++j)
    for (int k = g.col_ptr[j]; k < g.col_ptr[j + 1]; ++k) cg->values()[k] = g.h(g.rows[k], j);
  EXPECT_FALSE(cg->Factorize());
}

TEST(SparseQR, LeastSquaresAndNormalEquationsMatchADenseSolve) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const int n = 60, m = 150;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m, n);
  for (int i = 0; i < m; ++i)
    for (int k = 0; k < 4; ++k) a(i, (i * 7 + k * 13) % n) = u(rng);
  std::vector<int> col_ptr{0}, rows;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < m; ++i)
      if (a(i, j) != 0) rows.push_back(i);
    col_ptr.push_back(static_cast<int>(rows.size()));
  }
  SparseQR qr;
  qr.Analyze(m, n, col_ptr, rows);
  for (int j = 0; j < n; ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) qr.values()[k] = a(rows[k], j);
  ASSERT_TRUE(qr.Factorize());
  EXPECT_GT(qr.FactorNonZeros(), 0);
  Eigen::VectorXd b(m);
  for (int i = 0; i < m; ++i) b[i] = u(rng);
  Eigen::VectorXd x(n);
  qr.SolveLeastSquares(b.data(), x.data());
  const Eigen::VectorXd dense = a.colPivHouseholderQr().solve(b);
  EXPECT_LT((x - dense).norm(), 1e-10 * dense.norm());
  const Eigen::VectorXd g = a.transpose() * b;
  Eigen::VectorXd y(n);
  qr.SolveNormal(g.data(), y.data());
  EXPECT_LT((y - dense).norm(), 1e-8 * dense.norm());  // (A^T A)^-1 A^T b is the same x
}

}  // namespace
}  // namespace cairn
