// SE(3) factors: the between-factor shared by odometry and loop closures, and
// a prior on one pose. Residuals are U e with g2o's EDGE_SE3:QUAT /
// EDGE_SE3_PRIOR error e, so |r|^2 is g2o's chi-squared for the edge.
// Poses are stored as g2o writes them: (x, y, z, qx, qy, qz, qw).
#pragma once

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cairn/factors/pose_math.h"

namespace cairn::factors {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Between-factor on poses X_i, X_j, measurement Z:
//   D = X_i^-1 X_j = (q_i^-1 q_j,  q_i^-1 (t_j - t_i)),
//   E = Z^-1 D     = (q_z^-1 q_D,  q_z^-1 (t_D - t_z)),
//   e = (t_E, vec(q_E) with the sign that makes w(q_E) >= 0).
struct SE3BetweenFactor {
  SE3BetweenFactor(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                   const Matrix6d& sqrt_info)
      : qz_inv_(qz.conjugate()), tz_(tz), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* xi, const T* xj, T* residual) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> ti(xi), tj(xj);
    const Eigen::Map<const Eigen::Quaternion<T>> qi(xi + 3), qj(xj + 3);
    const Eigen::Quaternion<T> qi_inv = qi.conjugate();
    const Eigen::Quaternion<T> qz_inv = qz_inv_.cast<T>();
    const Vec3 t_d = qi_inv * (tj - ti);
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = qz_inv * (t_d - tz_.cast<T>());
    e.template tail<3>() = CompactQuaternion<T>(qz_inv * (qi_inv * qj));
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                                     const Matrix6d& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                       const Matrix6d& info, const double* const* p, double* r, double** J);

 private:
  Eigen::Quaterniond qz_inv_;
  Eigen::Vector3d tz_;
  Matrix6d sqrt_info_;
};

// Prior on one pose X with measurement Z: e = toVectorMQT(Z^-1 X).
struct SE3PriorFactor {
  SE3PriorFactor(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                 const Matrix6d& sqrt_info)
      : qz_inv_(qz.conjugate()), tz_(tz), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> t(x);
    const Eigen::Map<const Eigen::Quaternion<T>> q(x + 3);
    const Eigen::Quaternion<T> qz_inv = qz_inv_.cast<T>();
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = qz_inv * (t - tz_.cast<T>());
    e.template tail<3>() = CompactQuaternion<T>(qz_inv * q);
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                                     const Matrix6d& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                       const Matrix6d& info, const double* const* p, double* r, double** J);

 private:
  Eigen::Quaterniond qz_inv_;
  Eigen::Vector3d tz_;
  Matrix6d sqrt_info_;
};

}  // namespace cairn::factors
