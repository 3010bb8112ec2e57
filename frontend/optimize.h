// Pose-graph optimisation for the front-end, behind one call on the shared
// back-end (backend/solvers/ceres_solver.h, backend/solvers/graph_gauss_newton.h). Loop
// closures get a robust loss; odometry edges do not.
#pragma once

#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/solve_result.h"

namespace cairn::frontend {

struct OptimizeOptions {
  SolverKind solver = SolverKind::kCeres;  // Levenberg-Marquardt, or Gauss-Newton (IRLS)
  int max_iterations = 50;
  // Cauchy scale on loop closures, in units of the edge's standard deviation.
  double robust_scale = 2.0;
};

struct OptimizeSummary {
  int iterations = 0;
  double initial_chi2 = 0, final_chi2 = 0;  // g2o's, without the robust loss
};

// Optimises the 2D graph in place. With no fixed vertex, the first one is
// held fixed (the gauge).
OptimizeSummary OptimizeGraph(PoseGraph& graph, const OptimizeOptions& options = {});

}  // namespace cairn::frontend
