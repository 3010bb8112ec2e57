#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/se3_factors.h"

namespace cairn::factors {
namespace {
using Cost = AutoDiff<ceres::AutoDiffCostFunction<SE3PriorFactor, 6, 7>>;
}  // namespace

ceres::CostFunction* SE3PriorFactor::Create(const Eigen::Quaterniond& qz,
                                            const Eigen::Vector3d& tz, const Matrix6d& info) {
  return Cost::Create(SE3PriorFactor(qz.normalized(), tz, SqrtInformation<6>(info)));
}

bool SE3PriorFactor::Evaluate(const Eigen::Quaterniond& qz, const Eigen::Vector3d& tz,
                              const Matrix6d& info, const double* const* p, double* r,
                              double** J) {
  return Cost::Evaluate(SE3PriorFactor(qz.normalized(), tz, SqrtInformation<6>(info)), p, r, J);
}

}  // namespace cairn::factors
