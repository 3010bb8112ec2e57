// The odometry-calibration factor: a reference motion u* against the raw
// odometry increment u through an unknown 3x3 matrix X, u* = X u. Shared by
// the Ceres and the Gauss-Newton paths of `cairn calibrate`.
#pragma once

#include <ceres/cost_function.h>

#include <Eigen/Core>

namespace cairn::factors {

// Residual r = U (u* - X u) over the 9 entries of X stored row-major, with U
// the upper Cholesky factor of the pair's information (Omega = U^T U), so
// |r|^2 = e^T Omega e. The residual is linear in X, and its Jacobian
// -U (I3 kron u^T) does not depend on X: one Gauss-Newton step is exact.
struct OdometryCalibrationFactor {
  OdometryCalibrationFactor(const Eigen::Vector3d& u, const Eigen::Vector3d& u_star,
                            const Eigen::Matrix3d& sqrt_info)
      : u_(u), u_star_(u_star), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    Eigen::Matrix<T, 3, 1> e;
    for (int k = 0; k < 3; ++k)
      e[k] = T(u_star_[k]) - (x[3 * k] * u_[0] + x[3 * k + 1] * u_[1] + x[3 * k + 2] * u_[2]);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  // Owned by the caller (a Problem takes ownership once added). `info` is the
  // pair's 3x3 information matrix (symmetric positive definite).
  static ceres::CostFunction* Create(const Eigen::Vector3d& u, const Eigen::Vector3d& u_star,
                                     const Eigen::Matrix3d& info = Eigen::Matrix3d::Identity());

 private:
  Eigen::Vector3d u_, u_star_;
  Eigen::Matrix3d sqrt_info_;
};

}  // namespace cairn::factors
