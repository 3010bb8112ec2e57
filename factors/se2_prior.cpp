#include <ceres/autodiff_cost_function.h>

#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/se2_factors.h"

namespace cairn::factors {

ceres::CostFunction* SE2PriorFactor::Create(const Eigen::Vector3d& z,
                                            const Eigen::Matrix3d& info) {
  return new ceres::AutoDiffCostFunction<SE2PriorFactor, 3, 3>(
      new SE2PriorFactor(z, SqrtInformation<3>(info)));
}

bool SE2PriorFactor::Evaluate(const Eigen::Vector3d& z, const Eigen::Matrix3d& info,
                              const double* const* p, double* r, double** J) {
  return AutoDiffEvaluate<SE2PriorFactor, 3, 3>(SE2PriorFactor(z, SqrtInformation<3>(info)), p, r,
                                                J);
}

}  // namespace cairn::factors
