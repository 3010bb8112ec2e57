// The hand-written Gauss-Newton path: a linear problem in one step, the same
// optimum as Ceres on the same factors, gauge and fixed vertices, the damped
// fallback, and both linear solvers.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdlib>
#include <random>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/linear/domain_cholesky.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/linear/serial_scope.h"
#include "cairn/graph/simulate.h"
#include "cairn/linear/sparse_cholesky.h"

namespace cairn {
namespace {

// The seeds' odometry calibration: u*_i = X u_i, linear in the 9 entries of X.
struct CalibrationResidual {
  CalibrationResidual(const Eigen::Vector3d& u, const Eigen::Vector3d& u_star)
      : u_(u), u_star_(u_star) {}
  template <typename T>
  bool operator()(const T* x, T* r) const {
    for (int i = 0; i < 3; ++i)
      r[i] = T(u_star_[i]) - (x[3 * i] * u_[0] + x[3 * i + 1] * u_[1] + x[3 * i + 2] * u_[2]);
    return true;
  }
  Eigen::Vector3d u_, u_star_;
};

GaussNewtonOptions Quiet() {
  GaussNewtonOptions o;
  o.verbose = false;
  o.function_tolerance = 1e-12;  // tighter than the default: these compare optima
  o.parameter_tolerance = 1e-12;
  return o;
}

TEST(GaussNewton, LinearProblemConvergesInOneIteration) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3d x_true;
  x_true << 1.05, 0.02, 0.0, -0.01, 0.97, 0.0, 0.0, 0.01, 1.1;
  std::vector<Eigen::Vector3d> u, us;
  for (int i = 0; i < 50; ++i) {
    u.emplace_back(n(rng), n(rng), n(rng));
    us.push_back(x_true * u.back() + 0.01 * Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  // Closed form: each row of X from the normal equations (sum u u^T) x = sum u u*_k.
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero(), b = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < u.size(); ++i) {
    a += u[i] * u[i].transpose();
    b += u[i] * us[i].transpose();
  }
  const Eigen::Matrix3d x_closed = a.ldlt().solve(b).transpose();

  double x[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  GaussNewtonProblem problem;
  for (size_t i = 0; i < u.size(); ++i)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CalibrationResidual, 3, 9>(
                                 new CalibrationResidual(u[i], us[i])),
                             nullptr, {x});
  GaussNewtonOptions o = Quiet();
  o.function_tolerance = 1e-12;
  o.max_iterations = 1;
  const SolveResult r = problem.Solve(o);
  EXPECT_EQ(r.iterations, 1);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(x[i], x_closed(i / 3, i % 3), 1e-12) << i;
  // A second iteration finds nothing left to gain.
  o.max_iterations = 10;
  const SolveResult again = problem.Solve(o);
  EXPECT_LE(again.iterations, 1);
  EXPECT_NEAR(again.final_chi2, r.final_chi2, 1e-12 * r.final_chi2);
  EXPECT_TRUE(again.converged);
}

// The Ceres path (same factors, manifolds and gauge), tightly converged.
double SolveWithCeresTightly(PoseGraph& g) {
  CeresOptions o;
  o.function_tolerance = 1e-14;
  o.gradient_tolerance = 1e-14;
  o.parameter_tolerance = 1e-14;
  o.max_iterations = 200;
  return SolveWithCeres(g, o).final_chi2;
}

void ExpectSamePoses(const PoseGraph& a, const PoseGraph& b, double tol_m, double tol_rad) {
  const PoseDifference d = ComparePoses(a, b);
  EXPECT_LT(d.max_translation, tol_m);
  EXPECT_LT(d.max_rotation_deg * M_PI / 180.0, tol_rad);
}

class SameOptimumAsCeres : public ::testing::TestWithParam<int> {};

TEST_P(SameOptimumAsCeres, OnSimulatedGraph) {
  SimulationOptions so;
  so.dimension = GetParam();
  so.poses = 400;
  so.seed = 11;
  so.nodes_per_lap = 20;
  const Simulation sim = Simulate(so);
  PoseGraph gn = sim.noisy, ceres = sim.noisy;
  const SolveResult r = SolveGaussNewton(gn, Quiet());
  const double ceres_chi2 = SolveWithCeresTightly(ceres);
  EXPECT_TRUE(r.converged) << r.termination;
  EXPECT_NEAR(r.final_chi2, Chi2(gn), 1e-9 * r.final_chi2);
  EXPECT_NEAR(r.final_chi2 / ceres_chi2, 1.0, 1e-8);
  ExpectSamePoses(gn, ceres, 1e-5, 1e-6);
  // And close to the truth it was simulated from.
  EXPECT_LT(r.final_chi2, r.initial_chi2 * 1e-2);
  // Chi-squared never rises from one iteration to the next.
  for (size_t k = 1; k < r.trace.size(); ++k) EXPECT_LE(r.trace[k].chi2, r.trace[k - 1].chi2);
}

INSTANTIATE_TEST_SUITE_P(Dimensions, SameOptimumAsCeres, ::testing::Values(2, 3));

TEST(GaussNewton, GaugeAndFixedVerticesStayPut) {
  SimulationOptions so;
  so.poses = 200;
  so.seed = 5;
  Simulation sim = Simulate(so);
  PoseGraph g = sim.noisy;
  const PoseParams first = g.vertex(0).x;
  SolveGaussNewton(g, Quiet());
  EXPECT_EQ(g.vertex(0).x, first);  // the gauge: lowest id, no FIX

  PoseGraph h = sim.noisy;
  h.vertex(50).fixed = true;
  h.vertex(120).fixed = true;
  const PoseParams p50 = h.vertex(50).x, p120 = h.vertex(120).x, p0 = h.vertex(0).x;
  SolveGaussNewton(h, Quiet());
  EXPECT_EQ(h.vertex(50).x, p50);
  EXPECT_EQ(h.vertex(120).x, p120);
  EXPECT_NE(h.vertex(0).x, p0);  // no longer the gauge once vertices are fixed
}

TEST(GaussNewton, DampedFallbackNeverRaisesChi2) {
  // Rotations far from the truth make the first Gauss-Newton steps poor.
  SimulationOptions so;
  so.poses = 300;
  so.rotation_noise = 0.2;
  so.seed = 9;
  so.loop_probability = 1.0;
  Simulation sim = Simulate(so);
  PoseGraph g = sim.noisy;
  const SolveResult r = SolveGaussNewton(g, Quiet());
  EXPECT_LE(r.final_chi2, r.initial_chi2);
  for (size_t k = 1; k < r.trace.size(); ++k) EXPECT_LE(r.trace[k].chi2, r.trace[k - 1].chi2);
  EXPECT_TRUE(std::isfinite(r.final_chi2));
  EXPECT_NEAR(r.final_chi2, Chi2(g), 1e-9 * r.final_chi2);
}

TEST(GaussNewton, EveryLinearSolverAgrees) {
  SimulationOptions so;
  so.dimension = 3;
  so.poses = 300;
  so.nodes_per_lap = 15;
  const Simulation sim = Simulate(so);
  std::vector<PoseGraph> results;
  std::vector<double> chi2;
  for (CholeskyKind kind : {CholeskyKind::kSupernodal, CholeskyKind::kSimplicial,
                            CholeskyKind::kSupernodalOrSimplicial, CholeskyKind::kTwoHalves,
                            CholeskyKind::kEigenLDLT}) {
    PoseGraph g = sim.noisy;
    GaussNewtonOptions o = Quiet();
    o.linear_solver = kind;
    chi2.push_back(SolveGaussNewton(g, o).final_chi2);
    results.push_back(g);
  }
  for (size_t k = 1; k < results.size(); ++k) {
    EXPECT_NEAR(chi2[k] / chi2[0], 1.0, 1e-9);
    ExpectSamePoses(results[0], results[k], 1e-7, 1e-8);
  }
}

// A graph large enough for the factorisation in two halves at once, solved
// with it and with one CHOLMOD factorisation: the same steps.
TEST(GaussNewton, TwoHalvesAtOnceAgreeWithOneFactorisation) {
  SimulationOptions so;
  so.poses = 10000;
  so.nodes_per_lap = 100;
  const Simulation sim = Simulate(so);
  PoseGraph split = sim.noisy, whole = sim.noisy;
  GaussNewtonOptions o = Quiet();
  o.threads = 2;
  o.linear_solver = CholeskyKind::kTwoHalves;
  const SolveResult a = SolveGaussNewton(split, o);
  EXPECT_NE(a.linear_solver.find("two halves"), std::string::npos) << a.linear_solver;
  o.linear_solver = CholeskyKind::kSupernodal;
  const SolveResult b = SolveGaussNewton(whole, o);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_NEAR(a.final_chi2 / b.final_chi2, 1.0, 1e-9);
  ExpectSamePoses(split, whole, 1e-7, 1e-8);
}

TEST(GaussNewton, ThreadsDoNotChangeTheResult) {
  SimulationOptions so;
  so.poses = 500;
  const Simulation sim = Simulate(so);
  PoseGraph one = sim.noisy, four = sim.noisy;
  GaussNewtonOptions o = Quiet();
  o.threads = 1;
  const double a = SolveGaussNewton(one, o).final_chi2;
  o.threads = 4;
  const double b = SolveGaussNewton(four, o).final_chi2;
  EXPECT_EQ(a, b);
  for (size_t i = 0; i < one.vertices().size(); ++i)
    EXPECT_EQ(one.vertices()[i].x, four.vertices()[i].x);
}

TEST(GaussNewton, RobustLossDownWeightsAWrongLoopClosure) {
  SimulationOptions so;
  so.poses = 300;
  so.outliers = 1;
  so.seed = 21;
  const Simulation sim = Simulate(so);
  PoseGraph plain = sim.noisy, robust = sim.noisy;
  SolveGaussNewton(plain, Quiet());
  GaussNewtonOptions o = Quiet();
  o.loop_closure_loss = ParseRobustLoss("cauchy:1");
  SolveGaussNewton(robust, o);
  // Distance from the truth: the robust solve stays close, plain least squares is pulled away.
  auto error = [&](const PoseGraph& g) { return ComparePoses(g, sim.truth).max_translation; };
  EXPECT_LT(error(robust), 0.5);
  EXPECT_GT(error(plain), 2 * error(robust));
}


TEST(GaussNewton, ChordStepsReachTheSameOptimumWithFewerFactorisations) {
  SimulationOptions so;
  so.dimension = 3;
  so.poses = 400;
  so.nodes_per_lap = 20;
  so.seed = 12;
  const Simulation sim = Simulate(so);
  PoseGraph full = sim.noisy, chord = sim.noisy;
  GaussNewtonOptions o;
  o.verbose = false;
  o.function_tolerance = 1e-15;
  o.parameter_tolerance = 1e-12;
  o.gradient_tolerance = 1e-12;
  o.reuse_factorization = false;
  const SolveResult a = SolveGaussNewton(full, o);
  o.reuse_factorization = true;
  const SolveResult b = SolveGaussNewton(chord, o);
  EXPECT_EQ(a.reused_factorizations, 0);
  EXPECT_GT(b.reused_factorizations, 0);
  EXPECT_NEAR(b.final_chi2 / a.final_chi2, 1.0, 1e-12);
  for (size_t i = 0; i < full.vertices().size(); ++i)
    EXPECT_LT((ToSE3(full.vertices()[i].x).translation() -
               ToSE3(chord.vertices()[i].x).translation()).norm(),
              1e-7);
}


// The upper triangle (compressed columns) of a random sparse SPD matrix of
// 3x3 blocks: a chain of blocks plus a few random couplings, with every
// coupling between blocks i < j listed in block column j.
struct BlockMatrix {
  int blocks = 0;
  std::vector<std::pair<int, int>> couplings;  // (i, j), i < j
  Eigen::MatrixXd Dense(unsigned seed) const {
    const int n = 3 * blocks;
    std::srand(seed);
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
    for (const auto& [i, j] : couplings) {
      const Eigen::Matrix3d c = Eigen::Matrix3d::Random();
      a.block<3, 3>(3 * i, 3 * j) = c;
      a.block<3, 3>(3 * j, 3 * i) = c.transpose();
    }
    // Diagonally dominant, hence positive definite.
    for (int k = 0; k < n; ++k) a(k, k) = a.row(k).cwiseAbs().sum() + 1.0;
    return a;
  }
  // The pattern: full blocks, upper triangle only, rows sorted.
  void Pattern(std::vector<int>* col_ptr, std::vector<int>* rows) const {
    const int n = 3 * blocks;
    std::vector<std::vector<int>> above(blocks);  // block rows above the diagonal
    for (const auto& [i, j] : couplings) above[j].push_back(i);
    col_ptr->assign(1, 0);
    rows->clear();
    for (int b = 0; b < blocks; ++b) {
      std::sort(above[b].begin(), above[b].end());
      for (int c = 0; c < 3; ++c) {
        for (int i : above[b])
          for (int r = 0; r < 3; ++r) rows->push_back(3 * i + r);
        for (int r = 0; r <= c; ++r) rows->push_back(3 * b + r);
        col_ptr->push_back(static_cast<int>(rows->size()));
      }
    }
    (void)n;
  }
};

Eigen::VectorXd SolveWith(SparseCholesky& chol, const Eigen::MatrixXd& a,
                          const std::vector<int>& col_ptr, const std::vector<int>& rows,
                          const Eigen::VectorXd& b) {
  double* v = chol.values();
  for (int j = 0; j + 1 < static_cast<int>(col_ptr.size()); ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) v[k] = a(rows[k], j);
  EXPECT_TRUE(chol.Factorize());
  Eigen::VectorXd x(b.size());
  chol.Solve(b.data(), x.data());
  return x;
}

TEST(SparseCholesky, ExtendKeepsTheOrderAndSolvesTheGrownMatrix) {
  for (CholeskyKind kind : {CholeskyKind::kSupernodal, CholeskyKind::kSimplicial,
                            CholeskyKind::kSupernodalOrSimplicial}) {
    BlockMatrix m;
    m.blocks = 40;
    for (int i = 0; i + 1 < m.blocks; ++i) m.couplings.push_back({i, i + 1});
    for (int k = 0; k < 12; ++k) {
      const int i = (7 * k) % 30, j = i + 5 + k % 4;
      m.couplings.push_back({i, j});
    }
    std::vector<int> col_ptr, rows;
    m.Pattern(&col_ptr, &rows);
    auto chol = SparseCholesky::Create(kind);
    chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
    Eigen::MatrixXd a = m.Dense(1);
    Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1, 2);
    EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.ldlt().solve(b)).norm(), 1e-10);
    const std::vector<int> order = chol->BlockOrdering();

    // Two new blocks, coupled to old ones and to each other: columns at the end.
    BlockMatrix grown = m;
    grown.blocks += 2;
    grown.couplings.push_back({m.blocks - 1, m.blocks});
    grown.couplings.push_back({3, m.blocks});
    grown.couplings.push_back({m.blocks, m.blocks + 1});
    grown.couplings.push_back({17, m.blocks + 1});
    std::vector<int> grown_ptr, grown_rows;
    grown.Pattern(&grown_ptr, &grown_rows);
    ASSERT_TRUE(chol->Extend(3 * grown.blocks, grown_ptr, grown_rows,
                             std::vector<int>(grown.blocks, 3)));
    std::vector<int> extended = chol->BlockOrdering();
    if (!order.empty()) {
      ASSERT_EQ(extended.size(), order.size() + 2);
      EXPECT_TRUE(std::equal(order.begin(), order.end(), extended.begin()));
      EXPECT_EQ(extended[order.size()], m.blocks);
      EXPECT_EQ(extended[order.size() + 1], m.blocks + 1);
    }
    a = grown.Dense(2);
    b = Eigen::VectorXd::LinSpaced(a.rows(), 3, -1);
    EXPECT_LT((SolveWith(*chol, a, grown_ptr, grown_rows, b) - a.ldlt().solve(b)).norm(), 1e-10)
        << ToString(kind);

    // A coupling between two old blocks changes an old column: refused,
    // and the factorisation is left as it was.
    BlockMatrix changed = grown;
    changed.couplings.push_back({2, 20});
    std::vector<int> changed_ptr, changed_rows;
    changed.Pattern(&changed_ptr, &changed_rows);
    EXPECT_FALSE(chol->Extend(3 * changed.blocks, changed_ptr, changed_rows,
                              std::vector<int>(changed.blocks, 3)));
    EXPECT_LT((SolveWith(*chol, a, grown_ptr, grown_rows, b) - a.ldlt().solve(b)).norm(), 1e-10);
  }
}

// A grid of blocks (a city's streets) with a few long couplings: large
// enough to be cut into two halves, which CHOLMOD's single factorisation
// never sees.
BlockMatrix Grid(int side) {
  BlockMatrix m;
  m.blocks = side * side;
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c) {
      const int b = r * side + c;
      if (c + 1 < side) m.couplings.push_back({b, b + 1});
      if (r + 1 < side) m.couplings.push_back({b, b + side});
    }
  const int half = m.blocks / 2;
  for (int k = 0; k < 10; ++k) {
    const int i = (7 * k) % half, j = m.blocks - 1 - (11 * k) % half;
    if (j - i != 1 && j - i != side) m.couplings.push_back({i, j});
  }
  return m;
}

// A grid with its diagonals and couplings two apart: fill enough for the
// supernodal method in both halves.
BlockMatrix DenseGrid(int side) {
  BlockMatrix m = Grid(side);
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c) {
      const int b = r * side + c;
      if (c + 1 < side && r + 1 < side) m.couplings.push_back({b, b + side + 1});
      if (c + 2 < side) m.couplings.push_back({b, b + 2});
      if (r + 2 < side) m.couplings.push_back({b, b + 2 * side});
    }
  return m;
}

class TwoHalves : public ::testing::TestWithParam<bool> {};

TEST_P(TwoHalves, SolveExactly) {
  const bool dense = GetParam();
  const BlockMatrix m = dense ? DenseGrid(24) : Grid(24);
  std::vector<int> col_ptr, rows;
  m.Pattern(&col_ptr, &rows);
  const std::vector<int> sizes(m.blocks, 3);
  auto chol = CreateDomainCholesky(/*min_work=*/0);
  chol->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  ASSERT_NE(chol->Method().find("two halves"), std::string::npos) << chol->Method();
  // CHOLMOD's choice for the halves: the sparse grid's simplicial, the
  // denser one's supernodal; both ways of reading the separator's block.
  EXPECT_NE(chol->Method().find(dense ? "(supernodal, supernodal)" : "(simplicial, simplicial)"),
            std::string::npos) << chol->Method();
  const Eigen::MatrixXd a = m.Dense(5);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -2, 1);
  const Eigen::VectorXd expected = a.ldlt().solve(b);
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - expected).norm(), 1e-10 * expected.norm());
  // Its factor has the fill of one factorisation in the same order (the
  // separator's block counted dense).
  auto whole = SparseCholesky::Create(dense ? CholeskyKind::kSupernodal
                                            : CholeskyKind::kSimplicial);
  whole->SetBlockOrdering(chol->BlockOrdering());
  whole->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  SolveWith(*whole, a, col_ptr, rows, b);
  EXPECT_NEAR(static_cast<double>(chol->FactorNonZeros()) / whole->FactorNonZeros(), 1.0, 0.1);

  // Refactorised with other values, then with a given order (a graph that
  // grew): cut in that order's elimination tree.
  const Eigen::MatrixXd a2 = m.Dense(6);
  EXPECT_LT((SolveWith(*chol, a2, col_ptr, rows, b) - a2.ldlt().solve(b)).norm(), 1e-9);
  auto given = CreateDomainCholesky(0);
  given->SetBlockOrdering(chol->BlockOrdering());
  given->Analyze(3 * m.blocks, col_ptr, rows, sizes);
  EXPECT_NE(given->Method().find("two halves"), std::string::npos) << given->Method();
  EXPECT_LT((SolveWith(*given, a, col_ptr, rows, b) - expected).norm(), 1e-10 * expected.norm());
}

TEST_P(TwoHalves, RefuseAMatrixThatIsNotPositiveDefinite) {
  const BlockMatrix m = GetParam() ? DenseGrid(20) : Grid(20);
  std::vector<int> col_ptr, rows;
  m.Pattern(&col_ptr, &rows);
  auto chol = CreateDomainCholesky(0);
  chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
  ASSERT_NE(chol->Method().find("two halves"), std::string::npos);
  // Indefinite in each block in turn: in either half or in the separator.
  const Eigen::MatrixXd positive = m.Dense(7);
  double* v = chol->values();
  for (int j = 0; j + 1 < static_cast<int>(col_ptr.size()); ++j)
    for (int k = col_ptr[j]; k < col_ptr[j + 1]; ++k) v[k] = positive(rows[k], j);
  for (int block = 0; block < m.blocks; ++block) {
    const int diagonal = col_ptr[3 * block + 1] - 1;  // rows sorted: the last of its column
    const double kept = v[diagonal];
    v[diagonal] = -1;
    EXPECT_FALSE(chol->Factorize()) << "block " << block;
    v[diagonal] = kept;
  }
  // And positive definite again afterwards.
  const Eigen::MatrixXd a = m.Dense(8);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(a.rows());
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.ldlt().solve(b)).norm(), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(SparseCholesky, TwoHalves, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "Supernodal" : "Simplicial"; });

TEST(SparseCholesky, TwoHalvesLeaveASmallGraphToOneFactorisation) {
  BlockMatrix m = Grid(6);
  std::vector<int> col_ptr, rows;
  m.Pattern(&col_ptr, &rows);
  auto chol = SparseCholesky::Create(CholeskyKind::kTwoHalves);
  chol->Analyze(3 * m.blocks, col_ptr, rows, std::vector<int>(m.blocks, 3));
  EXPECT_EQ(chol->Method().find("two halves"), std::string::npos) << chol->Method();
  const Eigen::MatrixXd a = m.Dense(9);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(a.rows());
  EXPECT_LT((SolveWith(*chol, a, col_ptr, rows, b) - a.ldlt().solve(b)).norm(), 1e-10);
}


TEST(SerialLinearAlgebraScope, TurnsLibraryThreadsOffAndRestoresThem) {
  auto get_levels = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  auto get_blas = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  auto set_blas = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (!get_levels && !get_blas) GTEST_SKIP() << "neither OpenMP nor OpenBLAS is loaded";
  if (set_blas) set_blas(2);
  const int levels = get_levels ? get_levels() : 0;
  {
    SerialLinearAlgebraScope outer;
    if (get_levels) EXPECT_EQ(get_levels(), 0);
    if (get_blas) EXPECT_EQ(get_blas(), 1);
    {
      SerialLinearAlgebraScope inner;  // nests
      if (get_blas) EXPECT_EQ(get_blas(), 1);
    }
    if (get_levels) EXPECT_EQ(get_levels(), 0);
    if (get_blas) EXPECT_EQ(get_blas(), 1);
  }
  if (get_levels) EXPECT_EQ(get_levels(), levels);
  if (get_blas) EXPECT_EQ(get_blas(), 2);
}

}  // namespace
}  // namespace cairn
