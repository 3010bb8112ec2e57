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
  SolveResult r;
  if (options.solver == "ceres") {
    CeresOptions o;
    o.max_iterations = options.max_iterations;
    o.threads = 1;
    o.loop_closure_loss = loss;
    r = SolveWithCeres(graph, o);
  } else if (options.solver == "gn") {
    GaussNewtonOptions o;
    o.max_iterations = options.max_iterations;
    o.threads = 1;
    o.loop_closure_loss = loss;
    r = SolveGaussNewton(graph, o);
  } else {
    throw std::invalid_argument("unknown solver '" + options.solver + "' (ceres or gn)");
  }
  return {r.iterations, r.initial_chi2, r.final_chi2};
}

}  // namespace cairn::frontend
