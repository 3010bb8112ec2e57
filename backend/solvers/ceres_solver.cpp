#include "cairn/solvers/ceres_solver.h"

#include <ceres/covariance.h>
#include <ceres/iteration_callback.h>
#include <ceres/solver.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <iostream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cairn/graph/chi2.h"
#include "cairn/graph/runtime.h"
#include "cairn/linear/serial_scope.h"
#include "cairn/solvers/determinacy.h"
#include "cairn/solvers/graph_factors.h"
#include "cairn/linear/cholmod_common.h"
#include "cairn/factors/pose_manifold.h"

namespace cairn {
namespace {

class TraceCallback : public ceres::IterationCallback {
 public:
  TraceCallback(SolveResult* result, bool verbose) : result_(result), verbose_(verbose) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    IterationRecord r;
    r.iteration = s.iteration;
    r.chi2 = 2 * s.cost;
    r.step_norm = s.step_norm;
    r.time_s = s.cumulative_time_in_seconds;
    r.accepted = s.iteration == 0 || s.step_is_successful;
    r.linear_solver_time_s = s.step_solver_time_in_seconds;
    result_->trace.push_back(r);
    if (verbose_) std::cerr << FormatIteration(r) << "\n";
    return ceres::SOLVER_CONTINUE;
  }

 private:
  SolveResult* result_;
  bool verbose_;
};

std::string Termination(ceres::TerminationType type) {
  switch (type) {
    case ceres::CONVERGENCE:
    case ceres::USER_SUCCESS: return "convergence";
    case ceres::NO_CONVERGENCE: return "no_convergence";
    case ceres::FAILURE:
    case ceres::USER_FAILURE: return "failure";
  }
  return "failure";
}

ceres::SparseLinearAlgebraLibraryType SparseLibraryFor(CeresOptions::SparseLibrary choice) {
  switch (choice) {
    case CeresOptions::SparseLibrary::kSuiteSparse: return ceres::SUITE_SPARSE;
    case CeresOptions::SparseLibrary::kEigen: return ceres::EIGEN_SPARSE;
    case CeresOptions::SparseLibrary::kCxSparse: return ceres::CX_SPARSE;
    case CeresOptions::SparseLibrary::kAuto: break;
  }
  // SuiteSparse on every graph: measured ahead of CXSparse or level with it
  // on every shared file (docs/benchmarks.md, "The sparse Cholesky
  // library"). The measurement that had CXSparse below 150 flops per
  // nonzero of the factor predates OpenBLAS being held to one thread.
  return ceres::SUITE_SPARSE;
}

// The largest diagonal entry of any edge's information: the floor on LM's
// diagonal scales with it below 1, since Ceres clamps the diagonal of the
// Jacobi-scaled Jacobian, which is about the information itself when that is
// small, and a fixed floor would then damp every step.
double LargestInformation(const PoseGraph& graph) {
  double largest = 0;
  for (const Edge& e : graph.edges())
    largest = std::max(largest, e.information.diagonal().head(graph.ResidualSize(e)).maxCoeff());
  return largest;
}

// The unknowns Ceres solves for: the free blocks' tangent sizes.
int TangentUnknowns(ceres::Problem& problem) {
  std::vector<double*> blocks;
  problem.GetParameterBlocks(&blocks);
  int n = 0;
  for (double* b : blocks)
    if (!problem.IsParameterBlockConstant(b)) n += problem.ParameterBlockTangentSize(b);
  return n;
}

// Dense QR on a graph too large for it is refused as Ceres refuses a
// configuration: nothing solved, not usable. True when refused.
bool RefuseDenseQR(const ceres::Solver::Options& so, ceres::Problem& problem, SolveResult* result) {
  if (so.linear_solver_type != ceres::DENSE_QR || TangentUnknowns(problem) <= kMaxDenseQrUnknowns)
    return false;
  result->final_chi2 = result->initial_chi2;
  result->termination = "failure";
  result->message = "dense QR is for graphs of at most " + std::to_string(kMaxDenseQrUnknowns) +
                    " unknowns (its Jacobian is stored dense): use the Gauss-Newton path's sparse QR";
  return true;
}

}  // namespace

FactorEstimate EstimateFactor(const PoseGraph& graph) {
  // The pose-level pattern: one entry per pair of vertices an edge joins.
  std::vector<std::vector<int>> columns(graph.vertices().size());
  for (const Edge& e : graph.edges()) {
    int i = static_cast<int>(graph.VertexIndex(e.from));
    int j = e.IsPrior() ? i : static_cast<int>(graph.VertexIndex(e.to));
    if (i > j) std::swap(i, j);
    columns[j].push_back(i);  // upper triangle: row <= column
  }
  const int n = static_cast<int>(columns.size());
  size_t nnz = 0;
  for (int j = 0; j < n; ++j) {
    columns[j].push_back(j);
    std::sort(columns[j].begin(), columns[j].end());
    columns[j].erase(std::unique(columns[j].begin(), columns[j].end()), columns[j].end());
    nnz += columns[j].size();
  }
  FactorEstimate est;
  if (n == 0) return est;
  CholmodCommon holder;
  cholmod_common& cc = *holder.get();
  cc.nmethods = 1;
  cc.method[0].ordering = CHOLMOD_AMD;
  cc.supernodal = CHOLMOD_SIMPLICIAL;  // the counts are all we want
  cholmod_sparse* a = cholmod_allocate_sparse(n, n, nnz, 1, 1, 1, CHOLMOD_PATTERN, &cc);
  if (a) {
    auto* p = static_cast<int*>(a->p);
    auto* rows = static_cast<int*>(a->i);
    size_t k = 0;
    for (int j = 0; j < n; ++j) {
      p[j] = static_cast<int>(k);
      for (int r : columns[j]) rows[k++] = r;
    }
    p[n] = static_cast<int>(k);
    cholmod_factor* l = cholmod_analyze(a, &cc);
    if (l) {
      // Each pose-level entry is a dense b x b block: nonzeros grow by b^2,
      // flops (a sum of products of column counts) by b^3.
      const double b = graph.TangentSize();
      est.size = n * b;
      est.nonzeros = cc.lnz * b * b;
      est.flops = cc.fl * b * b * b;
      cholmod_free_factor(&l, &cc);
    }
    cholmod_free_sparse(&a, &cc);
  }
  return est;
}

CeresOptions::Method ParseCeresMethod(const std::string& text) {
  if (text == "lm" || text == "levenberg-marquardt") return CeresOptions::Method::kLevenbergMarquardt;
  if (text == "dogleg") return CeresOptions::Method::kDogleg;
  throw std::invalid_argument("unknown method '" + text + "' (expected lm or dogleg)");
}

CeresOptions::SparseLibrary ParseSparseLibrary(const std::string& text) {
  if (text == "auto") return CeresOptions::SparseLibrary::kAuto;
  if (text == "suitesparse") return CeresOptions::SparseLibrary::kSuiteSparse;
  if (text == "eigen") return CeresOptions::SparseLibrary::kEigen;
  if (text == "cxsparse") return CeresOptions::SparseLibrary::kCxSparse;
  throw std::invalid_argument("unknown sparse library '" + text +
                              "' (expected auto, suitesparse, eigen or cxsparse)");
}

CeresOptions::LinearSolver ParseCeresLinearSolver(const std::string& text) {
  if (text == "auto" || text == "cholesky") return CeresOptions::LinearSolver::kSparseNormalCholesky;
  if (text == "qr") return CeresOptions::LinearSolver::kDenseQR;
  if (text == "cg") return CeresOptions::LinearSolver::kCGNR;
  throw std::invalid_argument("unknown linear solver '" + text +
                              "' for the Ceres path (expected auto, cholesky, qr or cg)");
}

CeresGraphProblem::CeresGraphProblem(PoseGraph& graph, const RobustLoss& loop_closure_loss)
    : manifold_(graph.dimension() == 2 ? factors::MakeSE2Manifold()
                                       : factors::MakeSE3Manifold()),
      loop_closure_loss_(MakeLoss(loop_closure_loss)) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(po);

  // The same parameters and gauge as the Gauss-Newton path (graph_factors.h).
  const std::vector<bool> touched = TouchedVertices(graph);
  const GraphGauge gauge = ComputeGauge(graph);
  const std::vector<bool>& held = gauge.held;
  const int size = graph.ParameterSize();
  held_rotation_ = std::make_unique<HeldRotationManifold>(manifold_.get(), size == 7 ? 3 : 2);
  for (size_t i = 0; i < graph.vertices().size(); ++i) {
    if (!touched[i]) continue;
    Vertex& v = graph.vertices()[i];
    if (v.landmark) {
      problem_->AddParameterBlock(v.x.data(), graph.BlockSize(v));  // a point: no manifold
    } else {
      if (graph.dimension() == 3) {
        // The factors invert quaternions by conjugation, right only for unit ones.
        Eigen::Map<Eigen::Quaterniond>(v.x.data() + 3).normalize();
      }
      problem_->AddParameterBlock(v.x.data(), size,
                                  gauge.rotation_held[i] ? held_rotation_.get() : manifold_.get());
    }
    if (held[i]) {
      problem_->SetParameterBlockConstant(v.x.data());
      if (!v.fixed && !gauge_) gauge_ = v.id;  // the first component's
    }
  }

  for (const Edge& e : graph.edges()) {
    ceres::LossFunction* loss =
        e.kind == EdgeKind::kLoopClosure ? loop_closure_loss_.get() : nullptr;
    double* xi = graph.vertex(e.from).x.data();
    if (e.IsPrior()) {
      problem_->AddResidualBlock(MakeCostFunction(graph, e), loss, xi);
    } else {
      problem_->AddResidualBlock(MakeCostFunction(graph, e), loss, xi,
                                 graph.vertex(e.to).x.data());
    }
  }
}

ceres::Solver::Options MakeSolverOptions(const PoseGraph& graph, const CeresOptions& options) {
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = options.method == CeresOptions::Method::kDogleg
                                      ? ceres::DOGLEG
                                      : ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  if (options.linear_solver == CeresOptions::LinearSolver::kDenseQR) {
    so.linear_solver_type = ceres::DENSE_QR;
  } else if (options.linear_solver == CeresOptions::LinearSolver::kCGNR) {
    so.linear_solver_type = ceres::CGNR;
    so.preconditioner_type = ceres::JACOBI;
    // Ceres's defaults (eta 0.1, 500 iterations) leave each step inexact
    // enough that LM stops short of the optimum the direct solvers reach.
    so.eta = 1e-8;
    so.max_linear_solver_iterations = 20000;
  }
  so.sparse_linear_algebra_library_type = SparseLibraryFor(options.sparse_library);
  so.max_num_iterations = options.max_iterations;
  so.max_solver_time_in_seconds = options.max_time_s;
  so.num_threads = ResolveThreads(options.threads);
  so.function_tolerance = options.function_tolerance;
  // Relative instead, by RelativeGradientTest.
  so.gradient_tolerance = 0;
  so.parameter_tolerance = options.parameter_tolerance;
  so.jacobi_scaling = options.jacobi_scaling;
  so.initial_trust_region_radius = options.initial_trust_region_radius;
  so.min_lm_diagonal = options.min_lm_diagonal * std::min(1.0, LargestInformation(graph));
  so.use_postordering = options.use_postordering;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  return so;
}

SolveResult SolveWithCeres(PoseGraph& graph, const CeresOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const auto start = std::chrono::steady_clock::now();
  SolveResult result;
  result.solver = "ceres";

  // A non-finite start would only make Ceres fail deep inside; say which
  // vertex it is instead.
  if (const auto bad = FirstNonFiniteVertex(graph)) {
    result.initial_chi2 = result.final_chi2 = std::numeric_limits<double>::quiet_NaN();
    result.termination = "failure";
    result.message = "vertex " + std::to_string(*bad) + " has a non-finite estimate";
    result.time_s = Seconds(start);
    return result;
  }
  if (const auto why = FindUndetermined(graph, ComputeGauge(graph))) {
    result.initial_chi2 = result.final_chi2 = Chi2(graph);
    result.termination = "failure";
    result.message = *why;
    result.time_s = Seconds(start);
    return result;
  }
  CeresGraphProblem graph_problem(graph, options.loop_closure_loss);
  // After the problem is built: that normalises the quaternions g2o would.
  result.initial_chi2 = Chi2(graph);
  // The start, kept to fall back on should the solve end worse or non-finite.
  std::vector<PoseParams> start_estimate;
  start_estimate.reserve(graph.vertices().size());
  for (const Vertex& v : graph.vertices()) start_estimate.push_back(v.x);

  ceres::Solver::Options so = MakeSolverOptions(graph, options);
  result.linear_solver = ceres::LinearSolverTypeToString(so.linear_solver_type);
  if (so.linear_solver_type == ceres::SPARSE_NORMAL_CHOLESKY)
    result.linear_solver += std::string("/") + ceres::SparseLinearAlgebraLibraryTypeToString(
                                                   so.sparse_linear_algebra_library_type);
  if (RefuseDenseQR(so, graph_problem.problem(), &result)) {
    result.time_s = Seconds(start);
    return result;
  }
  TraceCallback callback(&result, options.verbose);
  so.callbacks.push_back(&callback);
  RelativeGradientTest gradient_test(options.gradient_tolerance,
                                     graph_problem.problem().NumResiduals());
  so.callbacks.push_back(&gradient_test);
  result.setup_time_s = Seconds(start);

  ceres::Solver::Summary summary;
  SerialLinearAlgebraScope serial;  // for CHOLMOD and BLAS inside Ceres as for ours
  ceres::Solve(so, &graph_problem.problem(), &summary);

  result.final_chi2 = Chi2(graph);
  const bool finite = !FirstNonFiniteVertex(graph) && std::isfinite(result.final_chi2);
  // Ceres's own cost includes the robust loss, which g2o's chi2 does not:
  // that is the objective that must not rise.
  const bool worse = summary.final_cost > summary.initial_cost;
  if (!finite || worse) {
    size_t k = 0;
    for (Vertex& v : graph.vertices()) v.x = start_estimate[k++];
    result.final_chi2 = Chi2(graph);
    result.termination = "failure";
    result.message = std::string(finite ? "the solve ended with a higher cost"
                                        : "the solve ended with a non-finite estimate") +
                     "; the starting estimate is kept (Ceres: " + summary.message + ")";
    result.converged = false;
    // The start is back: usable when it was finite.
    result.usable = IsUsableEstimate(result.final_chi2, result.final_chi2);
    result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    result.time_s = Seconds(start);
    return result;
  }
  // Ceres counts its starting point (iteration 0) as a successful step.
  result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  result.linearize_time_s = summary.jacobian_evaluation_time_in_seconds;
  result.linear_solver_time_s = summary.linear_solver_time_in_seconds;
  SetTermination(summary, gradient_test, &result);
  result.time_s = Seconds(start);
  return result;
}

ceres::CallbackReturnType RelativeGradientTest::operator()(const ceres::IterationSummary& s) {
  // g2o's chi2 (robustified when a loss is set) per residual.
  const double per_residual = 2 * s.cost / std::max(1, residuals_);
  if (s.iteration == 0 || s.gradient_max_norm > tolerance_ * per_residual)
    return ceres::SOLVER_CONTINUE;
  reached_ = true;
  return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
}

void SetTermination(const ceres::Solver::Summary& summary, const RelativeGradientTest& test,
                    SolveResult* result) {
  result->termination = Termination(summary.termination_type);
  result->message = test.reached() && summary.termination_type == ceres::USER_SUCCESS
                        ? "gradient tolerance reached (relative to chi2 per residual)"
                        : summary.message;
  result->converged = summary.termination_type == ceres::CONVERGENCE ||
                      (summary.termination_type == ceres::USER_SUCCESS && test.reached());
  // Ceres's cost includes the robust loss: the objective it minimised. A
  // configuration Ceres refused leaves both costs at -1: nothing was solved.
  result->usable = summary.initial_cost >= 0 &&
                   IsUsableEstimate(2 * summary.initial_cost, 2 * summary.final_cost);
}

std::vector<Eigen::MatrixXd> CeresMarginalCovariances(ceres::Problem& problem,
                                                      const std::vector<const double*>& blocks,
                                                      int threads) {
  std::vector<Eigen::MatrixXd> out;
  std::vector<std::pair<const double*, const double*>> pairs;
  for (const double* b : blocks) {
    const int tangent = problem.ParameterBlockTangentSize(b);
    out.push_back(Eigen::MatrixXd::Zero(tangent, tangent));
    // Ceres would answer zeros for a constant block too; asking for it only
    // costs a Jacobian column.
    if (!problem.IsParameterBlockConstant(b)) pairs.emplace_back(b, b);
  }
  if (pairs.empty()) return out;
  ceres::Covariance::Options options;
  options.num_threads = threads;
  // SPARSE_QR (the default) factors the Jacobian, not J^T J: it never squares
  // the condition number, so it is an independent check on the Cholesky path.
  options.algorithm_type = ceres::SPARSE_QR;
  ceres::Covariance covariance(options);
  if (!covariance.Compute(pairs, &problem))
    throw std::runtime_error("Ceres could not compute the covariance (rank-deficient Jacobian)");
  for (size_t k = 0; k < blocks.size(); ++k) {
    if (problem.IsParameterBlockConstant(blocks[k])) continue;
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(out[k].rows(),
                                                                             out[k].cols());
    covariance.GetCovarianceBlockInTangentSpace(blocks[k], blocks[k], c.data());
    out[k] = c;
  }
  return out;
}

}  // namespace cairn
