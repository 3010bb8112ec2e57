// One translation unit per factor: autodiff instantiation is slow to compile.
#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/se2_factors.h"

namespace cairn::factors {
namespace {
using Cost = AutoDiff<ceres::AutoDiffCostFunction<SE2BetweenFactor, 3, 3, 3>>;
}  // namespace

ceres::CostFunction* SE2BetweenFactor::Create(const Eigen::Vector3d& z,
                                              const Eigen::Matrix3d& info) {
  return Cost::Create(SE2BetweenFactor(z, SqrtInformation<3>(info)));
}

bool SE2BetweenFactor::Evaluate(const Eigen::Vector3d& z, const Eigen::Matrix3d& info,
                                const double* const* p, double* r, double** J) {
  return Cost::Evaluate(SE2BetweenFactor(z, SqrtInformation<3>(info)), p, r, J);
}

}  // namespace cairn::factors
