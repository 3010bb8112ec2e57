// Small templated helpers shared by the factor functors: angle wrapping and
// the quaternion error g2o reports. Templated so that Ceres's Jets pass through.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace cairn::factors {

// Wraps into [-pi, pi); floor keeps it smooth for Jets away from the cut.
template <typename T>
T WrapAngle(const T& a) {
  using std::floor;
  const T two_pi(2.0 * M_PI);
  return a - two_pi * floor((a + T(M_PI)) / two_pi);
}

// g2o's compact rotation error: the vector part of the quaternion, with the
// sign chosen so that w >= 0 (q and -q are the same rotation).
template <typename T>
Eigen::Matrix<T, 3, 1> CompactQuaternion(const Eigen::Quaternion<T>& q) {
  return q.w() < T(0) ? Eigen::Matrix<T, 3, 1>(-q.vec()) : Eigen::Matrix<T, 3, 1>(q.vec());
}

// Upper Cholesky factor U of an information matrix (Omega = U^T U): the
// residual U e gives e^T Omega e for any symmetric Omega. The lower factor
// would only be right for diagonal Omega.
template <int N>
Eigen::Matrix<double, N, N> SqrtInformation(const Eigen::Matrix<double, N, N>& info) {
  return info.llt().matrixU();
}

}  // namespace cairn::factors
