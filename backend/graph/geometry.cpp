#include "cairn/graph/geometry.h"

#include <cmath>

#include "cairn/factors/pose_math.h"

namespace cairn {

double NormalizeAngle(double a) {
  // factors::WrapAngle's convention. Out of range the arithmetic stays
  // fmod's rather than WrapAngle's floor: a file without vertices is placed
  // by composing SE2s, and every result on such a file (manhattan) depends
  // on those placements to the last bit.
  if (a >= -M_PI && a < M_PI) return a;
  double r = std::fmod(a + M_PI, 2.0 * M_PI);
  if (r < 0) r += 2.0 * M_PI;
  r -= M_PI;
  return r < M_PI ? r : -M_PI;  // r + 2 pi may round up to 2 pi
}

SE2::SE2(double x, double y, double theta) : x_(x), y_(y), theta_(NormalizeAngle(theta)) {}

Eigen::Matrix2d SE2::rotation() const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

SE2 SE2::operator*(const SE2& o) const {
  const Eigen::Vector2d t = translation() + rotation() * o.translation();
  return SE2(t.x(), t.y(), theta_ + o.theta_);
}

Eigen::Vector2d SE2::operator*(const Eigen::Vector2d& p) const {
  return rotation() * p + translation();
}

SE2 SE2::Inverse() const {
  const Eigen::Vector2d t = -(rotation().transpose() * translation());
  return SE2(t.x(), t.y(), -theta_);
}

SE3::SE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : q_(q.normalized()), t_(t) {}

SE3 SE3::FromVector(const Vector7d& v) {
  return SE3(Eigen::Quaterniond(v[6], v[3], v[4], v[5]), v.head<3>());
}

Vector7d SE3::ToVector() const {
  Vector7d v;
  v << t_, q_.x(), q_.y(), q_.z(), q_.w();
  return v;
}

SE3 SE3::FromEulerVector(const Vector6d& v) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX());
  return SE3(q, v.head<3>());
}

Vector6d SE3::ToEulerVector() const {
  const Eigen::Matrix3d r = q_.toRotationMatrix();
  // Roll-pitch-yaw of R = Rz(yaw) Ry(pitch) Rx(roll), pitch in [-pi/2, pi/2].
  const double roll = std::atan2(r(2, 1), r(2, 2));
  const double pitch = std::atan2(-r(2, 0), std::hypot(r(2, 1), r(2, 2)));
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  Vector6d v;
  v << t_, roll, pitch, yaw;
  return v;
}

SE3 SE3::operator*(const SE3& o) const { return SE3(q_ * o.q_, q_ * o.t_ + t_); }

SE3 SE3::Inverse() const {
  const Eigen::Quaterniond qi = q_.conjugate();
  return SE3(qi, -(qi * t_));
}

SE3 SE3::BoxPlus(const Vector6d& delta) const {
  return SE3(q_ * QuaternionExp(delta.tail<3>()), t_ + q_ * delta.head<3>());
}

Eigen::Quaterniond QuaternionExp(const Eigen::Vector3d& w) {
  return factors::QuaternionExp(w.data());
}

Eigen::Vector3d QuaternionLog(const Eigen::Quaterniond& q) {
  return factors::QuaternionLog(q.normalized());
}

SE2 ExpMap(const Eigen::Vector3d& d) { return SE2::FromVector(d); }

SE3 ExpMap(const Vector6d& d) {
  const Eigen::Vector3d w = d.tail<3>();
  return SE3(QuaternionExp(w), d.head<3>());
}

Eigen::Vector3d LogMap(const SE2& p) { return p.ToVector(); }

Vector6d LogMap(const SE3& p) {
  Vector6d v;
  v << p.translation(), QuaternionLog(p.rotation());
  return v;
}

Eigen::Matrix3d InverseAdjoint(const SE2& s) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
  const Eigen::Matrix2d rt = s.rotation().transpose();
  a.topLeftCorner<2, 2>() = rt;
  a.topRightCorner<2, 1>() = rt * Eigen::Vector2d(-s.y(), s.x());  // R^T J t
  return a;
}

Matrix6d InverseAdjoint(const SE3& s) {
  const Eigen::Matrix3d rt = s.rotation().toRotationMatrix().transpose();
  const Eigen::Vector3d t = s.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  Matrix6d a = Matrix6d::Zero();
  a.topLeftCorner<3, 3>() = rt;
  a.topRightCorner<3, 3>() = -rt * tx;
  a.bottomRightCorner<3, 3>() = rt;
  return a;
}

}  // namespace cairn
