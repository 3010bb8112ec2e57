// The tangent spaces both solvers step in. A pose's parameter block is its
// g2o vector ((x, y, theta) or (x, y, z, qx, qy, qz, qw)); an update is a
// right perturbation X <- X * Exp(delta), the way g2o's vertices apply it.
// The Gauss-Newton path chains the factors' Jacobians with PlusJacobian.
#pragma once

#include <ceres/manifold.h>

#include <memory>

namespace cairn::factors {

// Tangent (dx, dy, dtheta) in the pose's own frame; theta stays wrapped.
std::unique_ptr<ceres::Manifold> MakeSE2Manifold();
// Tangent (dt, dw): t <- t + R dt, q <- q * Exp(dw), dw a rotation vector.
std::unique_ptr<ceres::Manifold> MakeSE3Manifold();

}  // namespace cairn::factors
