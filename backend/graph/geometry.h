// Rigid-body poses in the plane (SE2) and in space (SE3), with the vector
// forms g2o files use and the box-plus both solvers step with.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace cairn {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;

// Wraps an angle into (-pi, pi], as g2o's SE2 keeps its rotation.
double NormalizeAngle(double a);

// A planar pose: translation (x, y) and heading theta, kept in (-pi, pi].
class SE2 {
 public:
  SE2() = default;
  SE2(double x, double y, double theta);
  // g2o's vector (x, y, theta).
  static SE2 FromVector(const Eigen::Vector3d& v) { return SE2(v[0], v[1], v[2]); }
  Eigen::Vector3d ToVector() const { return {x_, y_, theta_}; }

  double x() const { return x_; }
  double y() const { return y_; }
  double theta() const { return theta_; }
  Eigen::Vector2d translation() const { return {x_, y_}; }
  Eigen::Matrix2d rotation() const;

  SE2 operator*(const SE2& o) const;
  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const;
  SE2 Inverse() const;
  // The pose of `other` seen from this one: this^-1 * other.
  SE2 Between(const SE2& other) const { return Inverse() * other; }
  // Right perturbation: this * SE2(delta), the update both solvers apply.
  SE2 BoxPlus(const Eigen::Vector3d& delta) const { return *this * FromVector(delta); }

 private:
  double x_ = 0, y_ = 0, theta_ = 0;
};

// A pose in space: unit quaternion rotation and translation.
class SE3 {
 public:
  SE3() = default;
  SE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t);
  // g2o's vector (x, y, z, qx, qy, qz, qw); the quaternion is normalised.
  static SE3 FromVector(const Vector7d& v);
  Vector7d ToVector() const;
  // TORO's vector (x, y, z, roll, pitch, yaw), R = Rz(yaw) Ry(pitch) Rx(roll).
  static SE3 FromEulerVector(const Vector6d& v);
  Vector6d ToEulerVector() const;

  const Eigen::Quaterniond& rotation() const { return q_; }
  const Eigen::Vector3d& translation() const { return t_; }

  SE3 operator*(const SE3& o) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return q_ * p + t_; }
  SE3 Inverse() const;
  SE3 Between(const SE3& other) const { return Inverse() * other; }
  // Right perturbation by (dt, dw): t += R dt, q = q * Exp(dw), with dw a
  // rotation vector. The same retraction as factors/pose_manifold.h.
  SE3 BoxPlus(const Vector6d& delta) const;

 private:
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t_ = Eigen::Vector3d::Zero();
};

// Quaternion of a rotation vector (angle times unit axis); exact near zero.
Eigen::Quaterniond QuaternionExp(const Eigen::Vector3d& w);
// Rotation vector of a unit quaternion, with the angle in [0, pi].
Eigen::Vector3d QuaternionLog(const Eigen::Quaterniond& q);

}  // namespace cairn
