// The hand-written Gauss-Newton path: a linear problem in one step, the same
// optimum as Ceres on the same factors, gauge and fixed vertices, the damped
// fallback, and every linear solver under it (the factorisations alone are
// in tests/linear).
#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdlib>
#include <random>
#include <string>
#include <tuple>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/graph/chi2.h"
#include "cairn/graph/graph_io.h"
#include "cairn/solvers/graph_gauss_newton.h"
#include "cairn/solvers/linear_solver.h"
#include "cairn/graph/pose_difference.h"
#include "cairn/graph/simulate.h"
#include "test_util.h"

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

// r = a + B b + C c - t over blocks of sizes 2, 4 and 3: the worker's
// scratch for the ambient Jacobians is laid out per residual, the constant
// block in the middle taking none of it, and only a manifold's Jacobian goes
// through PlusJacobian.
struct ThreeBlockResidual {
  explicit ThreeBlockResidual(double t) : t_(t) {}
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    r[0] = a[0] + 2.0 * b[0] - b[3] + t_ * c[0] - t_;
    r[1] = a[1] + b[1] + 3.0 * c[1] - t_ * c[2] + 0.5 * t_;
    r[2] = t_ * a[0] - a[1] + b[2] + c[2] + c[0] - 2.0 * t_;
    return true;
  }
  double t_;
};

TEST(GaussNewton, MixedBlockSizesAndAConstantBlockInTheMiddle) {
  double a[2] = {0, 0}, b[4] = {1, 2, 3, 4}, c[3] = {0.5, 0.5, 0.5};
  ceres::EuclideanManifold<3> c_manifold;
  GaussNewtonProblem problem;
  problem.AddParameterBlock(c, 3, &c_manifold);
  for (double t : {1.0, -2.0, 0.25, 4.0}) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<ThreeBlockResidual, 3, 2, 4, 3>(new ThreeBlockResidual(t)),
        nullptr, {a, b, c});
  }
  problem.SetParameterBlockConstant(b);
  GaussNewtonOptions options;
  options.max_iterations = 5;
  problem.Solve(options);
  // The same linear least squares in a and c (b held), solved densely.
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(12, 5);
  Eigen::VectorXd y(12);
  int row = 0;
  for (double t : {1.0, -2.0, 0.25, 4.0}) {
    J.row(row) << 1, 0, t, 0, 0;
    y[row++] = t - (2.0 * 1 - 4);
    J.row(row) << 0, 1, 0, 3, -t;
    y[row++] = -0.5 * t - 2;
    J.row(row) << t, -1, 1, 0, 1;
    y[row++] = 2.0 * t - 3;
  }
  const Eigen::VectorXd x = J.colPivHouseholderQr().solve(y);
  EXPECT_NEAR(a[0], x[0], 1e-8);
  EXPECT_NEAR(a[1], x[1], 1e-8);
  EXPECT_NEAR(c[0], x[2], 1e-8);
  EXPECT_NEAR(c[1], x[3], 1e-8);
  EXPECT_NEAR(c[2], x[4], 1e-8);
  EXPECT_EQ(b[0], 1);
  EXPECT_EQ(b[3], 4);
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
    // The optimum is flat to rounding along its weakest directions: the
    // factorisations' different orders of summation leave the poses up to
    // 2.2e-7 m apart at a chi2 equal to 15 digits (measured with CHOLMOD's
    // simplicial and Eigen's LDLT against the supernodal one, on one
    // machine's BLAS; another gave under 1e-7).
    ExpectSamePoses(results[0], results[k], 1e-6, 1e-7);
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

}  // namespace
}  // namespace cairn

namespace cairn {
namespace {

// At the default tolerances: a solve that reuses factorisations ends where
// one that factorises at every step ends, on graphs whose chord steps slow
// down far from the optimum (larger noise, several seeds, 2D and 3D).
class ChordStepsAtDefaults : public ::testing::TestWithParam<int> {};

TEST_P(ChordStepsAtDefaults, NeverStopTheSolveEarly) {
  CAIRN_LONG_NUMERICAL_TEST();
  for (uint64_t seed : {1, 2, 3, 4}) {
    SimulationOptions so;
    so.dimension = GetParam();
    so.poses = 1500;
    so.seed = seed;
    so.rotation_noise = 0.03;
    so.translation_noise = 0.1;
    const Simulation sim = Simulate(so);
    PoseGraph full = sim.noisy, chord = sim.noisy;
    GaussNewtonOptions o;
    o.verbose = false;
    o.reuse_factorization = false;
    const SolveResult a = SolveGaussNewton(full, o);
    o.reuse_factorization = true;
    const SolveResult b = SolveGaussNewton(chord, o);
    ASSERT_TRUE(a.converged && b.converged) << a.message << " / " << b.message;
    EXPECT_NEAR(b.final_chi2 / a.final_chi2, 1.0, 1e-9) << "seed " << seed;
    EXPECT_LT(ComparePoses(full, chord).max_translation, 1e-5) << "seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(Dimensions, ChordStepsAtDefaults, ::testing::Values(2, 3));

// The default linear solver on a graph large enough to be split in two
// halves: one thread and two give the same estimate to the last bit.
TEST(GaussNewton, DefaultLinearSolverGivesTheSameBitsOnAnyThreadCount) {
  SimulationOptions so;
  so.poses = 10000;
  so.nodes_per_lap = 100;
  const Simulation sim = Simulate(so);
  PoseGraph one = sim.noisy, two = sim.noisy;
  GaussNewtonOptions o;
  o.verbose = false;
  o.threads = 1;
  const SolveResult a = SolveGaussNewton(one, o);
  o.threads = 2;
  const SolveResult b = SolveGaussNewton(two, o);
  EXPECT_NE(a.linear_solver.find("two halves"), std::string::npos) << a.linear_solver;
  EXPECT_EQ(a.linear_solver, b.linear_solver);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.final_chi2, b.final_chi2);
  for (size_t i = 0; i < one.vertices().size(); ++i)
    ASSERT_EQ(one.vertices()[i].x, two.vertices()[i].x) << "vertex " << i;
}

}  // namespace
}  // namespace cairn

namespace cairn {
namespace {

// Sparse QR of the Jacobian and conjugate gradients (both preconditioners)
// reach the optimum Cholesky reaches, at the default tolerances, on
// simulated 2D and 3D graphs of several seeds.
class OtherLinearSolvers
    : public ::testing::TestWithParam<std::tuple<int, CholeskyKind>> {};

TEST_P(OtherLinearSolvers, ReachTheCholeskyOptimum) {
  CAIRN_LONG_NUMERICAL_TEST();
  const auto [dimension, kind] = GetParam();
  for (uint64_t seed : {5, 6}) {
    SimulationOptions so;
    so.dimension = dimension;
    so.poses = 600;
    so.nodes_per_lap = 25;
    so.seed = seed;
    const Simulation sim = Simulate(so);
    PoseGraph cholesky = sim.noisy, other = sim.noisy;
    GaussNewtonOptions o;
    o.verbose = false;
    const SolveResult a = SolveGaussNewton(cholesky, o);
    o.linear_solver = kind;
    const SolveResult b = SolveGaussNewton(other, o);
    ASSERT_TRUE(b.converged) << b.message;
    EXPECT_EQ(b.linear_solver.substr(0, std::string(ToString(kind)).size()), ToString(kind));
    EXPECT_NEAR(b.final_chi2 / a.final_chi2, 1.0, 1e-9) << "seed " << seed;
    EXPECT_LT(ComparePoses(cholesky, other).max_translation, 1e-5) << "seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(
    DimensionsAndSolvers, OtherLinearSolvers,
    ::testing::Combine(::testing::Values(2, 3),
                       ::testing::Values(CholeskyKind::kQR, CholeskyKind::kConjugateGradients,
                                         CholeskyKind::kConjugateGradientsJacobi)));

// Far from the optimum Gauss-Newton steps fail and the damped fallback takes
// over: with QR its damping rows, with CG the damped H. Same end point.
TEST(GaussNewton, QRAndCGDampLikeCholesky) {
  SimulationOptions so;
  so.poses = 300;
  so.rotation_noise = 0.2;
  so.seed = 9;
  so.loop_probability = 1.0;
  const Simulation sim = Simulate(so);
  PoseGraph reference = sim.noisy;
  const SolveResult a = SolveGaussNewton(reference, Quiet());
  for (CholeskyKind kind : {CholeskyKind::kQR, CholeskyKind::kConjugateGradients}) {
    PoseGraph g = sim.noisy;
    GaussNewtonOptions o = Quiet();
    o.linear_solver = kind;
    const SolveResult b = SolveGaussNewton(g, o);
    for (size_t k = 1; k < b.trace.size(); ++k) EXPECT_LE(b.trace[k].chi2, b.trace[k - 1].chi2);
    EXPECT_NEAR(b.final_chi2 / a.final_chi2, 1.0, 1e-8) << ToString(kind);
  }
}

// parking-garage's H is badly conditioned: with a spanning-tree
// preconditioner alone CG ran to its iteration limit at every step and
// Gauss-Newton crept (1.2387290 after 15 iterations, against 1.2386906 in
// 7). The subgraph preconditioner must reach Cholesky's optimum in as many
// iterations.
TEST(ConjugateGradientsOnDataset, ParkingGarageReachesTheCholeskyOptimum) {
  const std::string path = testing::DatasetPath("g2o/3d/parking-garage.g2o");
  CAIRN_REQUIRE_DATASET(path);
  PoseGraph cholesky = ReadGraph(path), cg = cholesky;
  const SolveResult a = SolveGaussNewton(cholesky, Quiet());
  GaussNewtonOptions o = Quiet();
  o.linear_solver = CholeskyKind::kConjugateGradients;
  const SolveResult b = SolveGaussNewton(cg, o);
  ASSERT_TRUE(a.converged) << a.message;
  EXPECT_TRUE(b.converged) << b.message;
  EXPECT_NEAR(b.final_chi2 / a.final_chi2, 1.0, 1e-9) << b.linear_solver;
  EXPECT_LE(b.iterations, a.iterations + 1) << b.linear_solver;
  EXPECT_NE(b.linear_solver.find("subgraph"), std::string::npos) << b.linear_solver;
}

}  // namespace
}  // namespace cairn
