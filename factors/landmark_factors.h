// Point-landmark factors: a pose observing a point, and a prior on a point.
// Residuals are U e with g2o's EDGE_SE2_XY / EDGE_SE3_TRACKXYZ /
// EDGE_PRIOR_XY / EDGE_POINTXYZ_PRIOR error e, so |r|^2 is g2o's chi-squared
// for the edge. A point's parameter block is its coordinates (no manifold).
#pragma once

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cairn/factors/pose_math.h"

namespace cairn::factors {

// Pose x_i = (x, y, theta) observes point l = (x, y) at z (in the pose's
// frame): e = X_i^-1 l - z = R_i^T (l - t_i) - z.
struct SE2PointFactor {
  SE2PointFactor(const Eigen::Vector2d& z, const Eigen::Matrix2d& sqrt_info)
      : z_(z), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* xi, const T* l, T* residual) const {
    using std::cos;
    using std::sin;
    const T c = cos(xi[2]), s = sin(xi[2]);
    const T dx = l[0] - xi[0], dy = l[1] - xi[1];
    Eigen::Matrix<T, 2, 1> e;
    e << c * dx + s * dy - T(z_[0]), -s * dx + c * dy - T(z_[1]);
    Eigen::Map<Eigen::Matrix<T, 2, 1>> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& z, const Eigen::Matrix2d& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Eigen::Vector2d& z, const Eigen::Matrix2d& info, const double* const* p, double* r, double** J);

 private:
  Eigen::Vector2d z_;
  Eigen::Matrix2d sqrt_info_;
};

// Pose X_i = (t, q) observes point l at z through the sensor offset O =
// (t_o, q_o) (g2o's PARAMS_SE3OFFSET): e = (X_i O)^-1 l - z
// = q_o^-1 (q_i^-1 (l - t_i) - t_o) - z.
struct SE3PointFactor {
  SE3PointFactor(const Eigen::Vector3d& z, const Eigen::Quaterniond& q_offset,
                 const Eigen::Vector3d& t_offset, const Eigen::Matrix3d& sqrt_info)
      : z_(z), qo_inv_(q_offset.conjugate()), to_(t_offset), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* xi, const T* l, T* residual) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> ti(xi), p(l);
    const Eigen::Map<const Eigen::Quaternion<T>> qi(xi + 3);
    const Vec3 in_pose = qi.conjugate() * (p - ti);
    const Vec3 e = qo_inv_.cast<T>() * (in_pose - to_.cast<T>()) - z_.cast<T>();
    Eigen::Map<Vec3> r(residual);
    r = sqrt_info_.cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& z, const Eigen::Quaterniond& q_offset,
                                     const Eigen::Vector3d& t_offset, const Eigen::Matrix3d& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Eigen::Vector3d& z, const Eigen::Quaterniond& q_offset,
                       const Eigen::Vector3d& t_offset, const Eigen::Matrix3d& info, const double* const* p, double* r, double** J);

 private:
  Eigen::Vector3d z_;
  Eigen::Quaterniond qo_inv_;
  Eigen::Vector3d to_;
  Eigen::Matrix3d sqrt_info_;
};

// Prior on a point of N = 2 or 3 coordinates: e = l - z.
template <int N>
struct PointPriorFactor {
  using Vec = Eigen::Matrix<double, N, 1>;
  using Mat = Eigen::Matrix<double, N, N>;
  PointPriorFactor(const Vec& z, const Mat& sqrt_info) : z_(z), sqrt_info_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* l, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, N, 1>> p(l);
    Eigen::Map<Eigen::Matrix<T, N, 1>> r(residual);
    r = sqrt_info_.template cast<T>() * (p - z_.template cast<T>());
    return true;
  }

  static ceres::CostFunction* Create(const Vec& z, const Mat& info);
  // Create's cost function evaluated without the object (autodiff_evaluate.h).
  static bool Evaluate(const Vec& z, const Mat& info, const double* const* p, double* r, double** J);

 private:
  Vec z_;
  Mat sqrt_info_;
};

}  // namespace cairn::factors
