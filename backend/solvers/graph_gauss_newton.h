// The Gauss-Newton path on a pose graph: the same factors, manifolds and
// gauge as the Ceres path, solved by GaussNewtonProblem.
#pragma once

#include "cairn/solvers/gauss_newton.h"
#include "cairn/graph/pose_graph.h"

namespace cairn {

// Optimises the graph's vertices in place; options.loop_closure_loss
// robustifies loop-closure edges. initial_chi2 and final_chi2 are g2o's
// (without the robust loss), as on the Ceres path.
SolveResult SolveGaussNewton(PoseGraph& graph, const GaussNewtonOptions& options = {});

}  // namespace cairn
