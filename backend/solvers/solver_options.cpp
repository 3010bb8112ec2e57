// The range checks of the solvers' options, in one place: the solvers call
// them and throw, the `cairn` tool calls them before reading its input.
#include <cmath>
#include <string>

#include "cairn/solvers/ceres_solver.h"
#include "cairn/solvers/gauss_newton.h"
#include "cairn/solvers/incremental.h"
#include "cairn/solvers/solve_result.h"

namespace cairn {
namespace {

// Sets *error (when given) and returns false, so checks read as one line.
bool Fail(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

bool NonNegative(double v) { return std::isfinite(v) && v >= 0; }

}  // namespace

bool SolverOptions::IsValid(std::string* error) const {
  if (max_iterations < 0) return Fail(error, "max_iterations must not be negative");
  if (threads < 0) return Fail(error, "threads must not be negative (0: one per core)");
  if (!NonNegative(function_tolerance) || !NonNegative(gradient_tolerance) ||
      !NonNegative(parameter_tolerance))
    return Fail(error, "the function, gradient and parameter tolerances must be numbers >= 0");
  if (loop_closure_loss.kind != RobustLoss::kNone &&
      !(std::isfinite(loop_closure_loss.delta) && loop_closure_loss.delta > 0))
    return Fail(error, "the robust loss's width must be a positive number");
  return true;
}

bool CeresOptions::IsValid(std::string* error) const {
  if (!SolverOptions::IsValid(error)) return false;
  if (!(initial_trust_region_radius > 0))
    return Fail(error, "initial_trust_region_radius must be positive");
  if (!NonNegative(min_lm_diagonal)) return Fail(error, "min_lm_diagonal must be a number >= 0");
  if (!(max_time_s >= 0)) return Fail(error, "max_time_s must not be negative");
  return true;
}

bool GaussNewtonOptions::IsValid(std::string* error) const {
  if (!SolverOptions::IsValid(error)) return false;
  if (!NonNegative(damping)) return Fail(error, "damping must be a number >= 0");
  if (std::isnan(factor_memory_bytes)) return Fail(error, "factor_memory_bytes must be a number");
  return true;
}

bool IncrementalOptions::IsValid(std::string* error) const {
  std::string why;
  if (!ceres.IsValid(&why)) return Fail(error, "ceres: " + why);
  if (!gauss_newton.IsValid(&why)) return Fail(error, "gauss_newton: " + why);
  if (!NonNegative(reorder_growth)) return Fail(error, "reorder_growth must be a number >= 0");
  if (!partial.IsValid(&why)) return Fail(error, "partial: " + why);
  return true;
}

}  // namespace cairn
