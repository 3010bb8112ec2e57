#include <ceres/autodiff_cost_function.h>

#include "cairn/factors/se3_factors.h"

namespace cairn::factors {

ceres::CostFunction* SE3PriorFactor::Create(const Eigen::Quaterniond& qz,
                                            const Eigen::Vector3d& tz, const Matrix6d& info) {
  return new ceres::AutoDiffCostFunction<SE3PriorFactor, 6, 7>(
      new SE3PriorFactor(qz.normalized(), tz, SqrtInformation<6>(info)));
}

}  // namespace cairn::factors
