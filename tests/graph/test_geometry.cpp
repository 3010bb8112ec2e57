// SE2 and SE3 against values worked out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "cairn/graph/geometry.h"

namespace cairn {
namespace {

TEST(NormalizeAngle, WrapsIntoG2oHalfOpenInterval) {
  // [-pi, pi), g2o's normalize_theta, the factors' WrapAngle.
  EXPECT_DOUBLE_EQ(NormalizeAngle(0.5), 0.5);
  EXPECT_NEAR(NormalizeAngle(3 * M_PI / 2), -M_PI / 2, 1e-15);
  EXPECT_NEAR(NormalizeAngle(-3 * M_PI / 2), M_PI / 2, 1e-15);
  EXPECT_DOUBLE_EQ(NormalizeAngle(M_PI), -M_PI);
  EXPECT_DOUBLE_EQ(NormalizeAngle(-M_PI), -M_PI);
  EXPECT_NEAR(std::cos(NormalizeAngle(7 * M_PI)), -1, 1e-15);
  // In range: returned bit for bit; just below pi: not pushed past -pi.
  const double below_pi = std::nextafter(M_PI, 0.0);
  EXPECT_EQ(NormalizeAngle(below_pi), below_pi);
  for (double a : {3 * M_PI - 1e-15, -3 * M_PI, 1e6, -1e6, std::nextafter(3 * M_PI, 0.0)}) {
    const double r = NormalizeAngle(a);
    EXPECT_GE(r, -M_PI) << a;
    EXPECT_LT(r, M_PI) << a;
  }
  EXPECT_EQ(SE2(0, 0, M_PI).theta(), -M_PI);
}

TEST(SE2, ComposeByHand) {
  // (1, 2, 90deg) * (3, 0, 90deg): the second translation turns onto +y.
  const SE2 c = SE2(1, 2, M_PI / 2) * SE2(3, 0, M_PI / 2);
  EXPECT_NEAR(c.x(), 1, 1e-15);
  EXPECT_NEAR(c.y(), 5, 1e-15);
  EXPECT_NEAR(c.theta(), -M_PI, 1e-15);  // pi is kept as -pi
}

TEST(SE2, InverseAndBetween) {
  const SE2 a(1, 2, M_PI / 2);
  const SE2 ai = a.Inverse();
  // R^T = rot(-90): -(R^T t) = -(2, -1) = (-2, 1).
  EXPECT_NEAR(ai.x(), -2, 1e-15);
  EXPECT_NEAR(ai.y(), 1, 1e-15);
  EXPECT_NEAR(ai.theta(), -M_PI / 2, 1e-15);
  const SE2 b(1, 5, 0);
  const SE2 d = a.Between(b);  // b seen from a: 3 m straight ahead, turned -90.
  EXPECT_NEAR(d.x(), 3, 1e-15);
  EXPECT_NEAR(d.y(), 0, 1e-15);
  EXPECT_NEAR(d.theta(), -M_PI / 2, 1e-15);
  const SE2 back = a * d;
  EXPECT_NEAR(back.x(), b.x(), 1e-15);
  EXPECT_NEAR(back.y(), b.y(), 1e-15);
}

TEST(SE2, BoxPlusIsRightPerturbation) {
  const SE2 a(1, 1, M_PI / 2);
  const SE2 p = a.BoxPlus(Eigen::Vector3d(1, 0, 0.1));
  EXPECT_NEAR(p.x(), 1, 1e-15);  // one metre forward is +y here
  EXPECT_NEAR(p.y(), 2, 1e-15);
  EXPECT_NEAR(p.theta(), M_PI / 2 + 0.1, 1e-15);
  const SE2 wrapped = SE2(0, 0, 3.1).BoxPlus(Eigen::Vector3d(0, 0, 0.1));
  EXPECT_NEAR(wrapped.theta(), 3.2 - 2 * M_PI, 1e-15);
}

TEST(SE3, ComposeByHand) {
  const Eigen::Quaterniond rz(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const SE3 a(rz, Eigen::Vector3d(1, 0, 0));
  const SE3 b(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0));
  const SE3 c = a * b;  // 1 m along a's x axis, which is world y.
  EXPECT_TRUE(c.translation().isApprox(Eigen::Vector3d(1, 1, 0), 1e-15));
  EXPECT_TRUE(c.rotation().isApprox(rz));
  const SE3 id = a * a.Inverse();
  EXPECT_LT(id.translation().norm(), 1e-15);
  EXPECT_NEAR(std::abs(id.rotation().w()), 1, 1e-15);
  const SE3 d = a.Between(c);
  EXPECT_TRUE(d.translation().isApprox(b.translation(), 1e-15));
}

TEST(SE3, VectorsRoundTrip) {
  Vector7d v;
  v << 1, 2, 3, 0.1, -0.2, 0.3, std::sqrt(1 - 0.14);
  const SE3 p = SE3::FromVector(v);
  EXPECT_TRUE(p.ToVector().isApprox(v, 1e-15));
  Vector6d e;
  e << 1, 2, 3, 0.3, -0.4, 2.5;  // roll, pitch, yaw
  EXPECT_TRUE(SE3::FromEulerVector(e).ToEulerVector().isApprox(e, 1e-12));
  // Yaw alone is a rotation about z.
  Vector6d yaw;
  yaw << 0, 0, 0, 0, 0, M_PI / 2;
  EXPECT_TRUE(SE3::FromEulerVector(yaw).rotation().isApprox(
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()))));
}

TEST(SE3, BoxPlusAndExpLog) {
  const Eigen::Vector3d w(0.3, -0.2, 0.9);
  EXPECT_TRUE(QuaternionLog(QuaternionExp(w)).isApprox(w, 1e-14));
  EXPECT_TRUE(QuaternionExp(Eigen::Vector3d::Zero()).isApprox(Eigen::Quaterniond::Identity()));
  // Near pi the log stays on the short side.
  const Eigen::Vector3d nearly_pi(0, 0, M_PI - 1e-9);
  EXPECT_TRUE(QuaternionLog(QuaternionExp(nearly_pi)).isApprox(nearly_pi, 1e-9));
  const Eigen::Quaterniond rz(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const SE3 a(rz, Eigen::Vector3d(1, 0, 0));
  Vector6d d;
  d << 1, 0, 0, 0, 0, 0.5;
  const SE3 p = a.BoxPlus(d);
  EXPECT_TRUE(p.translation().isApprox(Eigen::Vector3d(1, 1, 0), 1e-15));
  EXPECT_NEAR(Eigen::AngleAxisd(p.rotation()).angle(), M_PI / 2 + 0.5, 1e-14);
}

TEST(Chart, ExpAndLogInvertEachOtherAndMatchBoxPlus) {
  const Eigen::Vector3d d2(0.4, -1.2, 2.9);
  EXPECT_TRUE(LogMap(ExpMap(d2)).isApprox(d2, 1e-15));
  const SE2 a(1, 2, 3.0);
  const SE2 pa = a * ExpMap(d2), pb = a.BoxPlus(d2);
  EXPECT_EQ(pa.ToVector(), pb.ToVector());
  Vector6d d3;
  d3 << 0.5, -0.1, 2, 0.3, -0.7, 1.1;
  EXPECT_TRUE(LogMap(ExpMap(d3)).isApprox(d3, 1e-14));
  const SE3 b(Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized())),
              Eigen::Vector3d(4, 5, 6));
  const SE3 qa = b * ExpMap(d3), qb = b.BoxPlus(d3);
  EXPECT_TRUE(qa.ToVector().isApprox(qb.ToVector(), 1e-15));
  // The rotation angle stays in [0, pi]: the short way round.
  EXPECT_LE(LogMap(SE3(QuaternionExp(Eigen::Vector3d(0, 0, 1.5 * M_PI)), Eigen::Vector3d::Zero()))
                .tail<3>()
                .norm(),
            M_PI);
}

// X ExpMap(d) S = X S ExpMap(InverseAdjoint(S) d) to first order: a small d
// moved past S agrees to O(|d|^2).
template <typename Pose, typename Tangent>
void ExpectAdjointCarriesPerturbation(const Pose& s, const Tangent& direction) {
  for (double h : {1e-4, 1e-5}) {
    const Tangent d = h * direction;
    const Tangent moved = LogMap(s.Inverse() * ExpMap(d) * s);
    const Tangent predicted = InverseAdjoint(s) * d;
    EXPECT_LT((moved - predicted).norm(), 10 * h * h) << h;
  }
  // Ad(S) undoes InverseAdjoint(S).
  const Eigen::MatrixXd product = InverseAdjoint(s.Inverse()) * InverseAdjoint(s);
  EXPECT_TRUE(product.isIdentity(1e-12));
}

TEST(Chart, InverseAdjointCarriesARightPerturbationPastAPose) {
  ExpectAdjointCarriesPerturbation(SE2(1.5, -2, 2.2), Eigen::Vector3d(0.3, -0.8, 0.5));
  Vector6d d;
  d << 0.2, 0.4, -0.6, 0.5, -0.3, 0.7;
  const SE3 s(Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(-1, 2, 0.5).normalized())),
              Eigen::Vector3d(3, -1, 2));
  ExpectAdjointCarriesPerturbation(s, d);
}

}  // namespace
}  // namespace cairn
