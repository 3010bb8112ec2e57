// The Gauss-Newton path on a pose graph: the same factors, manifolds and
// gauge as the Ceres path, solved by GaussNewtonProblem.
#pragma once

#include "backend/gauss_newton.h"
#include "backend/pose_graph.h"

namespace cairn {

// Optimises the graph's vertices in place. `loop_closure_loss` (owned by the
// caller, may be null) robustifies loop-closure edges.
SolveResult SolveGaussNewton(PoseGraph& graph, const GaussNewtonOptions& options,
                             const ceres::LossFunction* loop_closure_loss = nullptr);

}  // namespace cairn
