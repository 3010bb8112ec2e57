// One translation unit per factor: autodiff instantiation is slow to compile.
#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/landmark_factors.h"

namespace cairn::factors {
namespace {
using Cost = AutoDiff<ceres::AutoDiffCostFunction<SE2PointFactor, 2, 3, 2>>;
}  // namespace

ceres::CostFunction* SE2PointFactor::Create(const Eigen::Vector2d& z, const Eigen::Matrix2d& info) {
  return Cost::Create(SE2PointFactor(z, SqrtInformation<2>(info)));
}

bool SE2PointFactor::Evaluate(const Eigen::Vector2d& z, const Eigen::Matrix2d& info,
                              const double* const* p, double* r, double** J) {
  return Cost::Evaluate(SE2PointFactor(z, SqrtInformation<2>(info)), p, r, J);
}

}  // namespace cairn::factors
