// Marginal covariances of chosen poses: how certain the optimised estimate
// of each pose is, as the inverse of the information matrix (the Laplace
// approximation at the optimum). Two independent computations that check
// each other: Ceres's ceres::Covariance and the Gauss-Newton path's own
// sparse Cholesky factor. Covariances are in the manifold's tangent space
// (3x3 or 6x6, in the pose's own frame: x' = x * Exp(delta)); the vertex held
// to fix the gauge has none and gets zeros.
#pragma once

#include <ceres/problem.h>

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "cairn/solvers/incremental.h"
#include "cairn/graph/pose_graph.h"

namespace cairn {

// Ceres's covariance of the given parameter blocks of `problem` at their
// current values, in their manifolds' tangent spaces; zeros for constant
// blocks. Throws std::runtime_error when Ceres cannot compute it (a rank-
// deficient Jacobian).
std::vector<Eigen::MatrixXd> CeresMarginalCovariances(ceres::Problem& problem,
                                                      const std::vector<const double*>& blocks,
                                                      int threads = 1);

// The marginal covariances of the listed vertices of `graph` at its current
// estimate (normally the optimum), with the same factors and gauge as the
// solvers. Throws std::invalid_argument for an unknown vertex or one no edge
// touches, std::runtime_error when the information matrix is singular.
std::vector<Eigen::MatrixXd> MarginalCovariances(const PoseGraph& graph,
                                                 const std::vector<int64_t>& ids,
                                                 SolverKind solver = SolverKind::kCeres,
                                                 const RobustLoss& loop_closure_loss = {});

// Parses "3,17,42" into ids; throws std::invalid_argument on bad text.
std::vector<int64_t> ParseIdList(const std::string& text);

}  // namespace cairn
