// One translation unit per factor: autodiff instantiation is slow to compile.
#include "cairn/factors/odometry_calibration.h"

#include <ceres/autodiff_cost_function.h>

#include "cairn/factors/pose_math.h"

namespace cairn::factors {

ceres::CostFunction* OdometryCalibrationFactor::Create(const Eigen::Vector3d& u,
                                                       const Eigen::Vector3d& u_star,
                                                       const Eigen::Matrix3d& info) {
  return new ceres::AutoDiffCostFunction<OdometryCalibrationFactor, 3, 9>(
      new OdometryCalibrationFactor(u, u_star, SqrtInformation<3>(info)));
}

}  // namespace cairn::factors
