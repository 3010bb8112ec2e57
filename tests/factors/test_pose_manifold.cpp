// The pose manifolds' invariants, written once and run over SE(2) and SE(3),
// the checks Ceres's EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD makes: Plus(x, 0)
// = x, Minus(x, x) = 0, Minus(Plus(x, d), x) = d, Plus(x, Minus(y, x)) = y,
// and both Jacobians against central differences; then Plus against the
// geometry classes' BoxPlus, which both solvers' updates must agree with.
#include <gtest/gtest.h>

#include <ceres/manifold.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "pose_groups.h"

namespace cairn::testing {
namespace {

// Relative, as Ceres's matchers measure: |actual - expected| / |expected|.
constexpr double kExact = 1e-9;
// Central differences with this step are good to about 1e-9 here (the
// translations are up to 10 m); a wrong term is of order one.
constexpr double kStep = 1e-6;
constexpr double kNumeric = 1e-6;

template <typename M>
double RelativeError(const M& actual, const M& expected) {
  const double d = expected.norm();
  return d == 0 ? (actual - expected).norm() : (actual - expected).norm() / d;
}

template <typename G>
class PoseManifold : public ::testing::Test {
 protected:
  using Ambient = typename G::Ambient;
  using Tangent = typename G::Tangent;
  using PlusJacobianType = Eigen::Matrix<double, G::kAmbient, G::kTangent, Eigen::RowMajor>;
  using MinusJacobianType = Eigen::Matrix<double, G::kTangent, G::kAmbient, Eigen::RowMajor>;

  Ambient Plus(const Ambient& x, const Tangent& d) const {
    Ambient out;
    EXPECT_TRUE(manifold_->Plus(x.data(), d.data(), out.data()));
    return out;
  }
  Tangent Minus(const Ambient& y, const Ambient& x) const {
    Tangent out;
    EXPECT_TRUE(manifold_->Minus(y.data(), x.data(), out.data()));
    return out;
  }
  // Steps of every size: small, moderate, and turning by nearly pi.
  std::vector<Tangent> SampleSteps() {
    std::vector<Tangent> steps{Tangent::Zero()};
    // Minus gives back only rotations under pi: sigma 0.5 keeps well inside.
    for (double sigma : {1e-3, 0.1, 0.5}) steps.push_back(G::RandomTangent(rng_, sigma));
    for (double eps : {1e-6, 1e-3})
      for (int sign : {1, -1}) steps.push_back(G::LargeTangent(rng_, eps, sign));
    return steps;
  }

  Random rng_{31};
  const std::unique_ptr<ceres::Manifold> manifold_ = G::Manifold();
  const std::vector<typename G::Pose> poses_ = SamplePoses<G>(rng_);
};

TYPED_TEST_SUITE(PoseManifold, PoseGroups, PoseGroupNames);

TYPED_TEST(PoseManifold, SizesAreTheGroups) {
  EXPECT_EQ(this->manifold_->AmbientSize(), TypeParam::kAmbient);
  EXPECT_EQ(this->manifold_->TangentSize(), TypeParam::kTangent);
}

TYPED_TEST(PoseManifold, PlusZeroIsXAndMinusXIsZero) {
  using Tangent = typename TypeParam::Tangent;
  for (const auto& pose : this->poses_) {
    const auto x = TypeParam::ToAmbient(pose);
    EXPECT_LT(RelativeError(this->Plus(x, Tangent::Zero()), x), kExact) << x.transpose();
    EXPECT_LT(this->Minus(x, x).norm(), kExact) << x.transpose();
  }
}

TYPED_TEST(PoseManifold, MinusUndoesPlus) {
  for (const auto& pose : this->poses_) {
    const auto x = TypeParam::ToAmbient(pose);
    for (const auto& d : this->SampleSteps()) {
      const auto back = this->Minus(this->Plus(x, d), x);
      EXPECT_LT(RelativeError(back, d), kExact) << "x " << x.transpose() << "\nd " << d.transpose()
                                                << "\nback " << back.transpose();
    }
  }
}

// As poses: for SE(3) the quaternion may come back as -q, the same rotation.
TYPED_TEST(PoseManifold, PlusUndoesMinus) {
  const auto& poses = this->poses_;
  for (size_t k = 0; k < poses.size(); ++k) {
    const auto x = TypeParam::ToAmbient(poses[k]);
    const auto y = TypeParam::ToAmbient(poses[(k * 7 + 3) % poses.size()]);
    const auto there = this->Plus(x, this->Minus(y, x));
    EXPECT_LT(TypeParam::Distance(TypeParam::FromAmbient(there), TypeParam::FromAmbient(y)), 1e-9)
        << "x " << x.transpose() << "\ny " << y.transpose();
    EXPECT_LT(TypeParam::Distance(TypeParam::FromAmbient(this->Plus(x, this->Minus(x, x))),
                                  poses[k]),
              kExact);
  }
}

// The manifold and the geometry classes are written apart; the solvers
// step with one and the simulator and initialisation with the other.
TYPED_TEST(PoseManifold, PlusIsTheGeometrysBoxPlus) {
  for (const auto& pose : this->poses_) {
    for (const auto& d : this->SampleSteps()) {
      const auto plus = TypeParam::FromAmbient(this->Plus(TypeParam::ToAmbient(pose), d));
      EXPECT_LT(TypeParam::Distance(plus, TypeParam::Retract(pose, d)), 1e-12)
          << "d " << d.transpose();
    }
  }
}

TYPED_TEST(PoseManifold, PlusJacobianMatchesCentralDifferences) {
  using Tangent = typename TypeParam::Tangent;
  for (const auto& pose : this->poses_) {
    const auto x = TypeParam::ToAmbient(pose);
    typename TestFixture::PlusJacobianType numeric, actual;
    for (int k = 0; k < TypeParam::kTangent; ++k) {
      const Tangent h = kStep * Tangent::Unit(k);
      numeric.col(k) =
          TypeParam::AmbientDifference(this->Plus(x, h), this->Plus(x, -h)) / (2 * kStep);
    }
    ASSERT_TRUE(this->manifold_->PlusJacobian(x.data(), actual.data()));
    EXPECT_LT(RelativeError(actual, numeric), kNumeric)
        << "x " << x.transpose() << "\nactual\n" << actual << "\nnumeric\n" << numeric;
  }
}

TYPED_TEST(PoseManifold, MinusJacobianMatchesCentralDifferences) {
  using Ambient = typename TypeParam::Ambient;
  for (const auto& pose : this->poses_) {
    const Ambient x = TypeParam::ToAmbient(pose);
    typename TestFixture::MinusJacobianType numeric, actual;
    for (int k = 0; k < TypeParam::kAmbient; ++k) {
      const Ambient h = kStep * Ambient::Unit(k);
      numeric.col(k) = (this->Minus(x + h, x) - this->Minus(x - h, x)) / (2 * kStep);
    }
    ASSERT_TRUE(this->manifold_->MinusJacobian(x.data(), actual.data()));
    EXPECT_LT(RelativeError(actual, numeric), kNumeric)
        << "x " << x.transpose() << "\nactual\n" << actual << "\nnumeric\n" << numeric;
  }
}

// D Minus(Plus(x, d), x) at d = 0 is the identity, and Ceres's product with
// the Plus Jacobian (what it applies to every cost) is the plain product.
TYPED_TEST(PoseManifold, MinusJacobianInvertsPlusJacobian) {
  constexpr int kRows = 3;
  for (const auto& pose : this->poses_) {
    const auto x = TypeParam::ToAmbient(pose);
    typename TestFixture::PlusJacobianType plus;
    typename TestFixture::MinusJacobianType minus;
    ASSERT_TRUE(this->manifold_->PlusJacobian(x.data(), plus.data()));
    ASSERT_TRUE(this->manifold_->MinusJacobian(x.data(), minus.data()));
    const Eigen::MatrixXd product = minus * plus;
    const Eigen::MatrixXd identity =
        Eigen::MatrixXd::Identity(TypeParam::kTangent, TypeParam::kTangent);
    EXPECT_LT(RelativeError(product, identity), kExact);

    const Eigen::Matrix<double, kRows, TypeParam::kAmbient, Eigen::RowMajor> ambient =
        Eigen::Matrix<double, kRows, TypeParam::kAmbient, Eigen::RowMajor>::Random();
    Eigen::Matrix<double, kRows, TypeParam::kTangent, Eigen::RowMajor> tangent;
    ASSERT_TRUE(this->manifold_->RightMultiplyByPlusJacobian(x.data(), kRows, ambient.data(),
                                                             tangent.data()));
    const Eigen::MatrixXd expected = ambient * plus;
    EXPECT_LT(RelativeError(Eigen::MatrixXd(tangent), expected), kExact);
  }
}

}  // namespace
}  // namespace cairn::testing
