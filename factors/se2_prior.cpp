#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/se2_factors.h"

namespace cairn::factors {
namespace {
using Cost = AutoDiff<ceres::AutoDiffCostFunction<SE2PriorFactor, 3, 3>>;
}  // namespace

ceres::CostFunction* SE2PriorFactor::Create(const Eigen::Vector3d& z,
                                            const Eigen::Matrix3d& info) {
  return Cost::Create(SE2PriorFactor(z, SqrtInformation<3>(info)));
}

bool SE2PriorFactor::Evaluate(const Eigen::Vector3d& z, const Eigen::Matrix3d& info,
                              const double* const* p, double* r, double** J) {
  return Cost::Evaluate(SE2PriorFactor(z, SqrtInformation<3>(info)), p, r, J);
}

}  // namespace cairn::factors
