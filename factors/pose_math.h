// The Lie maths written once for the factors, the manifolds and SE2/SE3
// (backend/graph/geometry.h uses these): angle wrapping, the quaternion
// exponential and logarithm, the quaternion error g2o reports. Templated so
// that Ceres's Jets pass through.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>

namespace cairn::factors {

// Wraps into [-pi, pi), g2o's convention (normalize_theta). An angle already
// there is returned as it is; floor keeps the rest smooth for Jets away from
// the cut, and the last two steps catch (a + pi) rounding onto a multiple of
// 2 pi.
template <typename T>
T WrapAngle(const T& a) {
  using std::floor;
  const T pi(M_PI), two_pi(2.0 * M_PI);
  if (a >= -pi && a < pi) return a;
  T r = a - two_pi * floor((a + pi) / two_pi);
  if (r >= pi) r -= two_pi;
  if (r < -pi) r += two_pi;
  return r;
}

// Unit quaternion of a rotation vector w[0..2] (angle times unit axis).
// Below 1e-8 rad the series stand in for sin(x/2)/x and cos(x/2): no sqrt
// of zero, no division by a tiny angle, for Jets as for doubles.
template <typename T>
Eigen::Quaternion<T> QuaternionExp(const T* w) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta_sq = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  T k, c;
  if (theta_sq > T(1e-16)) {
    const T theta = sqrt(theta_sq);
    k = sin(T(0.5) * theta) / theta;
    c = cos(T(0.5) * theta);
  } else {
    k = T(0.5) - theta_sq / T(48.0);
    c = T(1.0) - theta_sq / T(8.0);
  }
  return Eigen::Quaternion<T>(c, k * w[0], k * w[1], k * w[2]);
}

// Rotation vector of a unit quaternion, angle in [0, pi] (q and -q are the
// same rotation, so w >= 0 is taken). The caller normalises.
template <typename T>
Eigen::Matrix<T, 3, 1> QuaternionLog(Eigen::Quaternion<T> q) {
  using std::atan2;
  using std::sqrt;
  if (q.w() < T(0)) q.coeffs() = -q.coeffs();
  const T s_sq = q.vec().squaredNorm();
  // 2 atan2(|v|, w) / |v| tends to 2 / w as |v| -> 0.
  const T k = s_sq > T(1e-24) ? T(2.0) * atan2(sqrt(s_sq), q.w()) / sqrt(s_sq) : T(2.0) / q.w();
  return k * q.vec();
}

// g2o's compact rotation error: the vector part of the quaternion, with the
// sign chosen so that w >= 0 (q and -q are the same rotation).
template <typename T>
Eigen::Matrix<T, 3, 1> CompactQuaternion(const Eigen::Quaternion<T>& q) {
  return q.w() < T(0) ? Eigen::Matrix<T, 3, 1>(-q.vec()) : Eigen::Matrix<T, 3, 1>(q.vec());
}

// A square root U of an information matrix with Omega = U^T U, so that the
// residual U e gives e^T Omega e (the lower Cholesky factor, Omega = L L^T,
// would only be right for diagonal Omega). Positive definite: the upper
// Cholesky factor. Singular (a position-only prior has no Cholesky factor):
// U = sqrt(Lambda) V^T from Omega = V Lambda V^T, eigenvalues within
// rounding of zero taken as zero, so the directions Omega gives no weight
// give no residual.
template <int N>
Eigen::Matrix<double, N, N> SqrtInformation(const Eigen::Matrix<double, N, N>& info) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(info);
  if (llt.info() == Eigen::Success) {
    Eigen::Matrix<double, N, N> u = llt.matrixU();
    if (u.diagonal().minCoeff() > 0) return u;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(info);
  const Eigen::Matrix<double, N, 1> root = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return root.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace cairn::factors
