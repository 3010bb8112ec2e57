#include "cairn/frontend/optimize.h"

#include <stdexcept>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/graph_gauss_newton.h"

namespace cairn::frontend {

// The shared back-end does the work; this keeps the front-end's few choices
// (robust loss on closures, one thread on a shared machine) in one place.
OptimizeSummary OptimizeGraph(PoseGraph& graph, const OptimizeOptions& options) {
  if (graph.dimension() != 2) throw std::invalid_argument("the front-end optimises 2D graphs");
  const RobustLoss loss{RobustLoss::kCauchy, options.robust_scale};
  SolverOptions common;
  common.max_iterations = options.max_iterations;
  common.threads = 1;
  common.loop_closure_loss = loss;
  const SolveResult r = options.solver == SolverKind::kCeres
                            ? SolveWithCeres(graph, CeresOptions(common))
                            : SolveGaussNewton(graph, GaussNewtonOptions(common));
  return {r.iterations, r.initial_chi2, r.final_chi2};
}

}  // namespace cairn::frontend
