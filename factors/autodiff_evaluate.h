// What ceres::AutoDiffCostFunction<F, M, Ns...>::Evaluate computes, for a
// functor that lives on the stack: a solver that evaluates its edges from
// the graph each time needs no cost object per edge (at a million edges
// those objects held 250 MB). Same Jets, same arithmetic, same digits.
#pragma once

#include <ceres/internal/autodiff.h>
#include <ceres/internal/parameter_dims.h>
#include <ceres/internal/variadic_evaluate.h>

namespace cairn::factors {

template <typename F, int M, int... Ns>
bool AutoDiffEvaluate(const F& functor, const double* const* parameters, double* residuals,
                      double** jacobians) {
  using Dims = ceres::internal::StaticParameterDims<Ns...>;
  if (!jacobians) return ceres::internal::VariadicEvaluate<Dims>(functor, parameters, residuals);
  return ceres::internal::AutoDifferentiate<M, Dims>(functor, parameters, M, residuals,
                                                     jacobians);
}

}  // namespace cairn::factors
