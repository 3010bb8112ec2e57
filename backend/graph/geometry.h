// Rigid-body poses in the plane (SE2) and in space (SE3), with the vector
// forms g2o files use, the box-plus both solvers step with, and its exponential,
// logarithm and adjoint. The templated maths underneath is factors/pose_math.h.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace cairn {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Wraps an angle into [-pi, pi), g2o's normalize_theta: the convention of
// factors::WrapAngle, which the factors and manifolds use, here for SE2.
double NormalizeAngle(double a);

// A planar pose: translation (x, y) and heading theta, kept in [-pi, pi).
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

// The chart of the box-plus, X.BoxPlus(d) = X * ExpMap(d) (to rounding), in
// tangent coordinates (t, w): SE2's d is its own vector (dx, dy, dtheta),
// SE3's is (dt, dw) with dw a rotation vector. LogMap inverts ExpMap (angles
// wrapped, rotation angles in [0, pi]). Not the group's exponential: the
// translation is not coupled to the rotation, exactly as both solvers step.
SE2 ExpMap(const Eigen::Vector3d& d);
SE3 ExpMap(const Vector6d& d);
Eigen::Vector3d LogMap(const SE2& p);
Vector6d LogMap(const SE3& p);

// The adjoint of s^-1 in that chart, to first order: it carries a
// perturbation on the right of X past s,
//   X ExpMap(d) s = X s ExpMap(InverseAdjoint(s) d).
// InverseAdjoint(s.Inverse()) is Ad(s), which maps a covariance of s^-1 to
// one of s.
Eigen::Matrix3d InverseAdjoint(const SE2& s);
Matrix6d InverseAdjoint(const SE3& s);

}  // namespace cairn
