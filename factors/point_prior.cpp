// One translation unit per factor: autodiff instantiation is slow to compile.
#include "cairn/factors/autodiff_evaluate.h"

#include "cairn/factors/landmark_factors.h"

namespace cairn::factors {
namespace {
template <int N>
using CostOf = AutoDiff<ceres::AutoDiffCostFunction<PointPriorFactor<N>, N, N>>;
}  // namespace

template <int N>
ceres::CostFunction* PointPriorFactor<N>::Create(const Vec& z, const Mat& info) {
  return CostOf<N>::Create(PointPriorFactor<N>(z, SqrtInformation<N>(info)));
}

template <int N>
bool PointPriorFactor<N>::Evaluate(const Vec& z, const Mat& info, const double* const* p, double* r,
                                   double** J) {
  return CostOf<N>::Evaluate(PointPriorFactor<N>(z, SqrtInformation<N>(info)), p, r, J);
}

template struct PointPriorFactor<2>;
template struct PointPriorFactor<3>;

}  // namespace cairn::factors
