#include "cairn/graph/geometry.h"

#include <cmath>

namespace cairn {

double NormalizeAngle(double a) {
  if (a > -M_PI && a <= M_PI) return a;
  double r = std::fmod(a + M_PI, 2.0 * M_PI);
  if (r <= 0) r += 2.0 * M_PI;
  return r - M_PI;
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
  const double theta = w.norm();
  const double half = 0.5 * theta;
  // sin(x/2)/x by its series below 1e-8: no division by a tiny angle.
  const double k = theta < 1e-8 ? 0.5 - theta * theta / 48.0 : std::sin(half) / theta;
  return Eigen::Quaterniond(std::cos(half), k * w.x(), k * w.y(), k * w.z());
}

Eigen::Vector3d QuaternionLog(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < 1e-12) return 2.0 * v;
  return 2.0 * std::atan2(s, q.w()) / s * v;
}

}  // namespace cairn
