// Marginal covariances of chosen poses: how certain the optimised estimate
// of each pose is, as the inverse of the information matrix (the Laplace
// approximation at the optimum). Two independent computations that check
// each other: Ceres's ceres::Covariance and the Gauss-Newton path's own
// sparse Cholesky factor. Covariances are in the manifold's tangent space
// (3x3 or 6x6, in the pose's own frame: x' = x * Exp(delta)); the vertex held
// to fix the gauge has none and gets zeros.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "cairn/graph/pose_graph.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {

// The marginal covariances of the listed vertices of `graph` at its current
// estimate (normally the optimum), with the same factors and gauge as the
// solvers. Throws std::invalid_argument for an unknown vertex or one no edge
// touches, std::runtime_error when the information matrix is singular.
std::vector<Eigen::MatrixXd> MarginalCovariances(const PoseGraph& graph,
                                                 const std::vector<int64_t>& ids,
                                                 SolverKind solver = SolverKind::kCeres,
                                                 const RobustLoss& loop_closure_loss = {});

}  // namespace cairn
