#include "cairn/factors/pose_manifold.h"

#include <ceres/autodiff_manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cairn/factors/pose_math.h"

namespace cairn::factors {
namespace {

struct SE2Plus {
  template <typename T>
  bool Plus(const T* x, const T* d, T* out) const {
    using std::cos;
    using std::sin;
    const T c = cos(x[2]), s = sin(x[2]);
    out[0] = x[0] + c * d[0] - s * d[1];
    out[1] = x[1] + s * d[0] + c * d[1];
    out[2] = WrapAngle(x[2] + d[2]);
    return true;
  }
  template <typename T>
  bool Minus(const T* y, const T* x, T* out) const {
    using std::cos;
    using std::sin;
    const T c = cos(x[2]), s = sin(x[2]);
    const T dx = y[0] - x[0], dy = y[1] - x[1];
    out[0] = c * dx + s * dy;
    out[1] = -s * dx + c * dy;
    out[2] = WrapAngle(y[2] - x[2]);
    return true;
  }
};

struct SE3Plus {
  template <typename T>
  bool Plus(const T* x, const T* d, T* out) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> t(x), dt(d);
    const Eigen::Map<const Eigen::Quaternion<T>> q(x + 3);
    Eigen::Map<Vec3> out_t(out);
    out_t = t + q * dt;
    Eigen::Map<Eigen::Quaternion<T>> out_q(out + 3);
    out_q = q * QuaternionExp(d + 3);
    return true;
  }
  template <typename T>
  bool Minus(const T* y, const T* x, T* out) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> tx(x), ty(y);
    const Eigen::Map<const Eigen::Quaternion<T>> qx(x + 3), qy(y + 3);
    const Eigen::Quaternion<T> qx_inv = qx.conjugate();
    Eigen::Map<Vec3> out_t(out);
    out_t = qx_inv * (ty - tx);
    Eigen::Map<Vec3> out_w(out + 3);
    out_w = QuaternionLog(Eigen::Quaternion<T>(qx_inv * qy));
    return true;
  }
};

}  // namespace

std::unique_ptr<ceres::Manifold> MakeSE2Manifold() {
  return std::make_unique<ceres::AutoDiffManifold<SE2Plus, 3, 3>>();
}

std::unique_ptr<ceres::Manifold> MakeSE3Manifold() {
  return std::make_unique<ceres::AutoDiffManifold<SE3Plus, 7, 6>>();
}

}  // namespace cairn::factors
