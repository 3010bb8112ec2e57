// A factor's cost function and its evaluation without one, from a single
// statement of its dimensions: AutoDiff<ceres::AutoDiffCostFunction<F, M,
// Ns...>>::Evaluate computes what that cost function's Evaluate does, for
// a functor that lives on the stack. A solver that evaluates its edges from
// the graph each time needs no cost object per edge (at a million edges
// those objects held 250 MB). Same Jets, same arithmetic, same digits.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/internal/autodiff.h>
#include <ceres/internal/parameter_dims.h>
#include <ceres/internal/variadic_evaluate.h>

#include <utility>

namespace cairn::factors {

template <typename Cost>
struct AutoDiff;

template <typename F, int M, int... Ns>
struct AutoDiff<ceres::AutoDiffCostFunction<F, M, Ns...>> {
  // Owned by the caller.
  static ceres::CostFunction* Create(F functor) {
    return new ceres::AutoDiffCostFunction<F, M, Ns...>(new F(std::move(functor)));
  }
  static bool Evaluate(const F& functor, const double* const* parameters, double* residuals,
                       double** jacobians) {
    using Dims = ceres::internal::StaticParameterDims<Ns...>;
    if (!jacobians) return ceres::internal::VariadicEvaluate<Dims>(functor, parameters, residuals);
    return ceres::internal::AutoDifferentiate<M, Dims>(functor, parameters, M, residuals,
                                                       jacobians);
  }
};

}  // namespace cairn::factors
