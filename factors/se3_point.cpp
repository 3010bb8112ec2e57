// One translation unit per factor: autodiff instantiation is slow to compile.
#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/landmark_factors.h"

namespace cairn::factors {
namespace {
using Cost = AutoDiff<ceres::AutoDiffCostFunction<SE3PointFactor, 3, 7, 3>>;
}  // namespace

ceres::CostFunction* SE3PointFactor::Create(const Eigen::Vector3d& z,
                                            const Eigen::Quaterniond& q_offset,
                                            const Eigen::Vector3d& t_offset,
                                            const Eigen::Matrix3d& info) {
  return Cost::Create(SE3PointFactor(z, q_offset.normalized(), t_offset, SqrtInformation<3>(info)));
}

bool SE3PointFactor::Evaluate(const Eigen::Vector3d& z, const Eigen::Quaterniond& q_offset,
                              const Eigen::Vector3d& t_offset, const Eigen::Matrix3d& info,
                              const double* const* p, double* r, double** J) {
  return Cost::Evaluate(SE3PointFactor(z, q_offset.normalized(), t_offset, SqrtInformation<3>(info)), p, r, J);
}

}  // namespace cairn::factors
