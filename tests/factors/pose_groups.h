// SE(2) and SE(3) behind one interface, so that the manifold and factor
// suites are written once and typed over both groups (as Sophus runs one
// suite over every group). Each group's struct names its manifold, its
// factors and g2o's error for its edges, and draws random poses.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "cairn/factors/pose_manifold.h"
#include "cairn/factors/se2_factors.h"
#include "cairn/factors/se3_factors.h"
#include "cairn/graph/geometry.h"

namespace cairn::testing {

class Random {
 public:
  explicit Random(unsigned seed) : gen_(seed) {}
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(gen_); }
  double Normal(double sigma) { return std::normal_distribution<>(0, sigma)(gen_); }
  template <int N>
  Eigen::Matrix<double, N, 1> NormalVector(double sigma) {
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v[i] = Normal(sigma);
    return v;
  }
  // Symmetric positive definite with off-diagonal terms of the same order
  // as the diagonal, so that the lower and upper Cholesky factors differ.
  template <int N>
  Eigen::Matrix<double, N, N> Information() {
    Eigen::Matrix<double, N, N> b;
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) b(i, j) = Normal(1);
    return b * b.transpose() + 0.5 * Eigen::Matrix<double, N, N>::Identity();
  }

 private:
  std::mt19937 gen_;
};

struct SE2Group {
  static constexpr int kAmbient = 3, kTangent = 3;
  using Pose = SE2;
  using Ambient = Eigen::Matrix<double, kAmbient, 1>;
  using Tangent = Eigen::Matrix<double, kTangent, 1>;
  using Information = Eigen::Matrix<double, kTangent, kTangent>;

  static std::unique_ptr<ceres::Manifold> Manifold() { return factors::MakeSE2Manifold(); }

  static Pose RandomPose(Random& rng) { return Pose(rng.Uniform(-10, 10), rng.Uniform(-10, 10),
                                                    rng.Uniform(-M_PI, M_PI)); }
  // Heading sign * (pi - eps): two of opposite signs straddle the wrap.
  static Pose NearHalfTurn(Random& rng, double eps, int sign) {
    return Pose(rng.Uniform(-10, 10), rng.Uniform(-10, 10), sign * (M_PI - eps));
  }
  static Tangent RandomTangent(Random& rng, double sigma) { return rng.NormalVector<3>(sigma); }
  // A step turning by sign * (pi - eps), the largest Minus can give back.
  static Tangent LargeTangent(Random& rng, double eps, int sign) {
    return Tangent(rng.Normal(1), rng.Normal(1), sign * (M_PI - eps));
  }
  static Pose Noise(Random& rng, double sigma) { return Pose::FromVector(RandomTangent(rng, sigma)); }
  static Pose Retract(const Pose& x, const Tangent& d) { return x.BoxPlus(d); }

  static Ambient ToAmbient(const Pose& x) { return x.ToVector(); }
  static Pose FromAmbient(const Ambient& v) { return Pose::FromVector(v); }
  // The same pose under other parameters: the heading a turn away.
  static Ambient Alias(Ambient v) {
    v[2] += v[2] > 0 ? -2 * M_PI : 2 * M_PI;
    return v;
  }
  // a - b where the heading is continuous: Plus wraps it, a chart need not.
  static Ambient AmbientDifference(const Ambient& a, const Ambient& b) {
    Ambient d = a - b;
    d[2] = NormalizeAngle(d[2]);
    return d;
  }
  static double Distance(const Pose& a, const Pose& b) {
    const Pose e = a.Between(b);
    return e.translation().norm() + std::abs(e.theta());
  }

  // g2o's EDGE_SE2 / EDGE_PRIOR_SE2 error of the residual pose E = Z^-1 D.
  static Tangent G2oError(const Pose& e) { return e.ToVector(); }
  static ceres::CostFunction* Between(const Pose& z, const Information& info) {
    return factors::SE2BetweenFactor::Create(z.ToVector(), info);
  }
  static ceres::CostFunction* Prior(const Pose& z, const Information& info) {
    return factors::SE2PriorFactor::Create(z.ToVector(), info);
  }
};

struct SE3Group {
  static constexpr int kAmbient = 7, kTangent = 6;
  using Pose = SE3;
  using Ambient = Eigen::Matrix<double, kAmbient, 1>;
  using Tangent = Eigen::Matrix<double, kTangent, 1>;
  using Information = Eigen::Matrix<double, kTangent, kTangent>;

  static std::unique_ptr<ceres::Manifold> Manifold() { return factors::MakeSE3Manifold(); }

  static Pose RandomPose(Random& rng) {
    return Pose(Eigen::Quaterniond(rng.NormalVector<4>(1)), Translation(rng));
  }
  // A rotation by pi - eps about a random axis: w close to zero, so the
  // quaternion's sign is about to flip.
  static Pose NearHalfTurn(Random& rng, double eps, int sign) {
    const Eigen::Vector3d axis = sign * rng.NormalVector<3>(1).normalized();
    return Pose(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI - eps, axis)), Translation(rng));
  }
  static Tangent RandomTangent(Random& rng, double sigma) { return rng.NormalVector<6>(sigma); }
  static Tangent LargeTangent(Random& rng, double eps, int sign) {
    Tangent d;
    d << rng.NormalVector<3>(1), sign * (M_PI - eps) * rng.NormalVector<3>(1).normalized();
    return d;
  }
  static Pose Noise(Random& rng, double sigma) { return Pose().BoxPlus(RandomTangent(rng, sigma)); }
  static Pose Retract(const Pose& x, const Tangent& d) { return x.BoxPlus(d); }

  static Ambient ToAmbient(const Pose& x) { return x.ToVector(); }
  static Pose FromAmbient(const Ambient& v) { return Pose::FromVector(v); }
  // The same pose under other parameters: q and -q are the same rotation.
  static Ambient Alias(Ambient v) {
    v.tail<4>() = -v.tail<4>();
    return v;
  }
  static Ambient AmbientDifference(const Ambient& a, const Ambient& b) { return a - b; }
  static double Distance(const Pose& a, const Pose& b) {
    const Pose e = a.Between(b);
    const Eigen::Quaterniond& q = e.rotation();
    return e.translation().norm() + 2 * std::atan2(q.vec().norm(), std::abs(q.w()));
  }

  // g2o's EDGE_SE3:QUAT / EDGE_SE3_PRIOR error of E = Z^-1 D: translation
  // and the quaternion's vector part with the sign that makes w >= 0.
  static Tangent G2oError(const Pose& e) {
    Eigen::Quaterniond q = e.rotation();
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    Tangent out;
    out << e.translation(), q.vec();
    return out;
  }
  static ceres::CostFunction* Between(const Pose& z, const Information& info) {
    return factors::SE3BetweenFactor::Create(z.rotation(), z.translation(), info);
  }
  static ceres::CostFunction* Prior(const Pose& z, const Information& info) {
    return factors::SE3PriorFactor::Create(z.rotation(), z.translation(), info);
  }

 private:
  static Eigen::Vector3d Translation(Random& rng) {
    return Eigen::Vector3d(rng.Uniform(-10, 10), rng.Uniform(-10, 10), rng.Uniform(-10, 10));
  }
};

// Random poses, a third of them turned by nearly pi (both ways, several
// distances from it), where quaternion signs flip and headings wrap.
template <typename G>
std::vector<typename G::Pose> SamplePoses(Random& rng) {
  std::vector<typename G::Pose> poses;
  for (int k = 0; k < 30; ++k) poses.push_back(G::RandomPose(rng));
  for (double eps : {1e-9, 1e-6, 1e-3})
    for (int sign : {1, -1})
      for (int k = 0; k < 2; ++k) poses.push_back(G::NearHalfTurn(rng, eps, sign));
  return poses;
}

using PoseGroups = ::testing::Types<SE2Group, SE3Group>;

// Names the typed suites' instances SE2 and SE3 in the test names.
struct PoseGroupNames {
  template <typename G>
  static std::string GetName(int) {
    return std::is_same_v<G, SE2Group> ? "SE2" : "SE3";
  }
};

}  // namespace cairn::testing
