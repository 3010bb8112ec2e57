// SE(2) factors: the between-factor shared by odometry and loop closures, and
// a prior on one pose. Residuals are U e with g2o's EDGE_SE2 / EDGE_PRIOR_SE2
// error e, so |r|^2 is g2o's chi-squared for the edge.
#pragma once

#include <ceres/cost_function.h>

#include <Eigen/Core>

#include "cairn/factors/pose_math.h"

namespace cairn::factors {

// Between-factor on poses x_i, x_j = (x, y, theta), measurement Z:
//   D = X_i^-1 X_j,  E = Z^-1 D,
//   e = (R_z^T (t_D - t_z),  wrap(theta_j - theta_i - theta_z)),
//   t_D = R_i^T (t_j - t_i).
struct SE2BetweenFactor {
  SE2BetweenFactor(const Eigen::Vector3d& z, const Eigen::Matrix3d& sqrt_info)
      : z_(z), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* xi, const T* xj, T* residual) const {
    using std::cos;
    using std::sin;
    const T ci = cos(xi[2]), si = sin(xi[2]);
    const T dx = xj[0] - xi[0], dy = xj[1] - xi[1];
    // t_D - t_z, then rotated by R_z^T.
    const T tx = ci * dx + si * dy - T(z_[0]);
    const T ty = -si * dx + ci * dy - T(z_[1]);
    const double cz = std::cos(z_[2]), sz = std::sin(z_[2]);
    Eigen::Matrix<T, 3, 1> e;
    e << T(cz) * tx + T(sz) * ty, T(-sz) * tx + T(cz) * ty,
        WrapAngle(xj[2] - xi[2] - T(z_[2]));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  // Owned by the caller (Ceres's Problem takes ownership once added).
  static ceres::CostFunction* Create(const Eigen::Vector3d& z, const Eigen::Matrix3d& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Eigen::Vector3d& z, const Eigen::Matrix3d& info, const double* const* p, double* r, double** J);

 private:
  Eigen::Vector3d z_;
  Eigen::Matrix3d sqrt_info_;
};

// Prior on one pose x with measurement Z: e = toVector(Z^-1 X).
struct SE2PriorFactor {
  SE2PriorFactor(const Eigen::Vector3d& z, const Eigen::Matrix3d& sqrt_info)
      : z_(z), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    const double cz = std::cos(z_[2]), sz = std::sin(z_[2]);
    const T dx = x[0] - T(z_[0]), dy = x[1] - T(z_[1]);
    Eigen::Matrix<T, 3, 1> e;
    e << T(cz) * dx + T(sz) * dy, T(-sz) * dx + T(cz) * dy, WrapAngle(x[2] - T(z_[2]));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& z, const Eigen::Matrix3d& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Eigen::Vector3d& z, const Eigen::Matrix3d& info, const double* const* p, double* r, double** J);

 private:
  Eigen::Vector3d z_;
  Eigen::Matrix3d sqrt_info_;
};

}  // namespace cairn::factors
