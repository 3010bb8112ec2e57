// The two other ways to solve the Gauss-Newton step: conjugate gradients
// (each preconditioner) on H, and sparse QR on the Jacobian itself, each
// against a dense solve of the same system.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <string>
#include <utility>
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

// The subgraph preconditioner's "N of M other blocks" from its Method().
std::pair<int, int> SubgraphBlocks(const std::string& method) {
  const size_t at = method.find(" other blocks");
  if (at == std::string::npos) return {-1, -1};
  const size_t of = method.rfind(" of ", at);
  const size_t from = method.rfind(' ', of - 1);
  return {std::stoi(method.substr(from + 1, of - from - 1)),
          std::stoi(method.substr(of + 4, at - of - 4))};
}

struct CgCase {
  Preconditioner preconditioner;
  double subgraph_fill;
  const char* method;  // what Method() names
};

TEST(ConjugateGradients, EveryPreconditionerSolvesAPoseGraphsNormalEquations) {
  // The subgraph with a budget that takes some of the other blocks, and
  // with one that takes them all (then H is its own preconditioner).
  const CgCase cases[] = {{Preconditioner::kBlockJacobi, 4, "block-Jacobi"},
                          {Preconditioner::kSpanningTree, 4, "spanning-tree"},
                          {Preconditioner::kSubgraph, 1.3, "subgraph"},
                          {Preconditioner::kSubgraph, 100, "subgraph"}};
  for (const CgCase& c : cases) {
    for (unsigned seed : {1u, 2u, 3u}) {
      const GraphMatrix g = MakeGraphMatrix(120, 60, seed);
      ConjugateGradientsOptions o;
      o.preconditioner = c.preconditioner;
      o.subgraph_fill = c.subgraph_fill;
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
      const std::string method = cg->Method();
      EXPECT_NEAR(model(x) / model(exact), 1.0, 1e-10) << method << ", seed " << seed;
      EXPECT_LT((x - exact).norm(), 1e-4 * exact.norm()) << method << ", seed " << seed;
      EXPECT_NE(method.find(c.method), std::string::npos) << method;
      if (c.preconditioner != Preconditioner::kSubgraph) continue;
      const auto [taken, others] = SubgraphBlocks(method);
      ASSERT_GT(others, 0) << method;
      if (c.subgraph_fill > 10) {
        EXPECT_EQ(taken, others) << method;
        // Its own preconditioner: the first step is exact.
        EXPECT_LT((x - exact).norm(), 1e-10 * exact.norm()) << method;
      } else {
        EXPECT_GT(taken, 0) << method;
        EXPECT_LT(taken, others) << method;
        EXPECT_LE(cg->FactorNonZeros(), 1.3 * 9 * (n / 3 + others + n / 3)) << method;
      }
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
