// One translation unit per factor: autodiff instantiation is slow to compile.
#include <ceres/autodiff_cost_function.h>

#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/landmark_factors.h"

namespace cairn::factors {

template <int N>
ceres::CostFunction* PointPriorFactor<N>::Create(const Vec& z, const Mat& info) {
  return new ceres::AutoDiffCostFunction<PointPriorFactor<N>, N, N>(
      new PointPriorFactor<N>(z, SqrtInformation<N>(info)));
}

template <int N>
bool PointPriorFactor<N>::Evaluate(const Vec& z, const Mat& info, const double* const* p, double* r,
                                   double** J) {
  return AutoDiffEvaluate<PointPriorFactor<N>, N, N>(PointPriorFactor<N>(z, SqrtInformation<N>(info)),
                                                     p, r, J);
}

template struct PointPriorFactor<2>;
template struct PointPriorFactor<3>;

}  // namespace cairn::factors
