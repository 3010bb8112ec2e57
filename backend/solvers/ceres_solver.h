// The Ceres back-end: a pose graph as a ceres::Problem (one parameter block
// per pose on the SE2/SE3 manifold, g2o's factors as residuals), solved in
// place with Levenberg-Marquardt or dogleg on a sparse Cholesky.
#pragma once

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/iteration_callback.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <cstdint>
#include <memory>
#include <optional>

#include "cairn/graph/pose_graph.h"
#include "cairn/graph/runtime.h"  // ResolveThreads
#include "cairn/solvers/solve_result.h"

namespace cairn {

struct CeresOptions : SolverOptions {
  enum class Method { kLevenbergMarquardt, kDogleg };
  // kAuto picks per graph what measured fastest (see docs/benchmarks.md):
  // SuiteSparse's supernodal factorisation pays on 3D graphs, whose normal
  // matrices have dense 6x6 blocks; planar graphs factor as fast simplicial.
  enum class SparseLibrary { kAuto, kSuiteSparse, kEigen, kCxSparse };
  // How each step's linear system is solved: sparse Cholesky of J^T J,
  // Ceres's dense QR of J (small graphs only: kMaxDenseQrUnknowns), or
  // conjugate gradients on the normal equations (CGNR, Jacobi-
  // preconditioned, solved tightly enough to reach the Cholesky optimum).
  enum class LinearSolver { kSparseNormalCholesky, kDenseQR, kCGNR };

  CeresOptions() = default;
  // The shared settings (iterations, tolerances, threads, loss) taken from
  // `common`, the Ceres ones at their defaults.
  explicit CeresOptions(const SolverOptions& common) : SolverOptions(common) {}

  Method method = Method::kLevenbergMarquardt;
  SparseLibrary sparse_library = SparseLibrary::kAuto;
  LinearSolver linear_solver = LinearSolver::kSparseNormalCholesky;
  bool jacobi_scaling = true;
  // A large first radius starts LM close to Gauss-Newton, which pose graphs
  // started from odometry usually tolerate; LM shrinks it when they do not.
  // Ceres's 1e4 damps too long (19 iterations on sphere2500, 6 here); 1e12
  // lets the first steps of sphere_bignoise fall into a worse minimum.
  double initial_trust_region_radius = 1e10;
  // Ceres's floor on LM's (Jacobi-scaled) diagonal, times the largest
  // information entry when that is below 1, so that tiny information is not
  // damped by the floor alone.
  double min_lm_diagonal = 1e-6;
  // Let the sparse Cholesky library order the normal matrix itself (AMD with
  // its postordering) rather than Ceres pre-permuting the Jacobian's columns.
  bool use_postordering = false;
  double max_time_s = 1e9;

  // SolverOptions::IsValid, and the trust-region settings and time limit
  // within the ranges Ceres accepts.
  bool IsValid(std::string* error) const;
};

// The sparse Cholesky factor of a graph's normal matrix as SuiteSparse's
// symbolic analysis (AMD) predicts it, scaled from the pose level to scalars.
struct FactorEstimate {
  double size = 0;            // rows of the normal matrix
  double nonzeros = 0;        // in the factor L
  double flops = 0;           // of one factorisation
  double FlopsPerNonzero() const { return nonzeros > 0 ? flops / nonzeros : 0; }
};
FactorEstimate EstimateFactor(const PoseGraph& graph);

// Parses "lm"/"levenberg-marquardt" and "dogleg"; throws std::invalid_argument.
CeresOptions::Method ParseCeresMethod(const std::string& text);
// Parses "auto", "suitesparse", "eigen", "cxsparse"; throws std::invalid_argument.
CeresOptions::SparseLibrary ParseSparseLibrary(const std::string& text);
// Parses "auto" or "cholesky" (sparse normal Cholesky), "qr" (dense QR) and
// "cg" (CGNR); throws std::invalid_argument.
CeresOptions::LinearSolver ParseCeresLinearSolver(const std::string& text);
// The largest tangent dimension Ceres's dense QR is used for: its Jacobian
// is stored dense (a 2000-unknown graph's is about 50 MB) and factorised in
// O(m n^2). SolveWithCeres refuses larger graphs with this choice.
constexpr int kMaxDenseQrUnknowns = 2000;

// A pose graph laid out as a Ceres problem over the graph's own vertex
// arrays. Only vertices that some edge touches become parameter blocks.
// Vertices marked fixed are held constant; when none is and no prior anchors
// the graph, the lowest-id vertex is held (the gauge). SE3 vertices'
// quaternions are normalised in place first, as g2o does on reading.
class CeresGraphProblem {
 public:
  CeresGraphProblem(PoseGraph& graph, const RobustLoss& loop_closure_loss);
  CeresGraphProblem(const CeresGraphProblem&) = delete;
  CeresGraphProblem& operator=(const CeresGraphProblem&) = delete;

  ceres::Problem& problem() { return *problem_; }
  // The vertex held only to fix the gauge, if one was needed.
  std::optional<int64_t> gauge_vertex() const { return gauge_; }

 private:
  // The problem borrows the manifold and loss (one object for all blocks),
  // so they are declared first and destroyed after it.
  std::unique_ptr<ceres::Manifold> manifold_;
  std::unique_ptr<ceres::Manifold> held_rotation_;  // for a rotation gauge
  std::unique_ptr<ceres::LossFunction> loop_closure_loss_;
  std::unique_ptr<ceres::Problem> problem_;
  std::optional<int64_t> gauge_;
};

// Ceres's solver settings for these options on this graph (the sparse
// library chosen per graph when kAuto); shared by the batch and incremental
// paths. Callbacks are the caller's to add.
ceres::Solver::Options MakeSolverOptions(const PoseGraph& graph, const CeresOptions& options);

// Ceres's own gradient test is absolute, so that scaling the information
// would move where it stops: MakeSolverOptions switches it off and this
// callback stops the solve instead once the gradient's largest component
// falls to `tolerance` times chi2 per residual (`residuals` of them), which
// is about 1 at the optimum of a graph whose information matches its noise:
// there the test reads as Ceres's absolute one. Ceres's gradient is the
// projected one, x - Plus(x, -g), proportional to the tangent gradient only
// while that is small: with information scaled up by many orders the test
// fires early (the function and parameter tests are not affected). Add it
// to the options' callbacks.
class RelativeGradientTest : public ceres::IterationCallback {
 public:
  RelativeGradientTest(double tolerance, int residuals)
      : tolerance_(tolerance), residuals_(residuals) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;
  bool reached() const { return reached_; }

 private:
  double tolerance_;
  int residuals_;
  bool reached_ = false;
};

// termination, message, converged and usable of `result` from Ceres's
// summary, by the rule solve_result.h states; shared by the batch and
// incremental paths.
void SetTermination(const ceres::Solver::Summary& summary, const RelativeGradientTest& test,
                    SolveResult* result);

// Optimises the graph's vertices in place. initial_chi2 and final_chi2 are
// g2o's (without the robust loss); the per-iteration trace holds twice
// Ceres's cost, which includes the loss when one is set.
SolveResult SolveWithCeres(PoseGraph& graph, const CeresOptions& options = {});

// Ceres's covariance of the given parameter blocks of `problem` at their
// current values, in their manifolds' tangent spaces; zeros for constant
// blocks. Throws std::runtime_error when Ceres cannot compute it (a rank-
// deficient Jacobian).
std::vector<Eigen::MatrixXd> CeresMarginalCovariances(ceres::Problem& problem,
                                                      const std::vector<const double*>& blocks,
                                                      int threads = 1);

}  // namespace cairn
