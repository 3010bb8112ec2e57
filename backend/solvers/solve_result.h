// What every solver of a pose graph (the Ceres path and cairn's own
// Gauss-Newton path) accepts and returns, so that `cairn optimize`, the
// tests and the benchmarks treat them alike. Chi-squared is g2o's throughout:
// the sum over edges of e^T Omega e, i.e. twice Ceres's cost.
#pragma once

#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

namespace cairn {

// Which of the two solvers runs: the Ceres path or cairn's own Gauss-Newton.
enum class SolverKind { kCeres, kGaussNewton };

// Parses "ceres" and "gn" (the names `--solver` takes); throws
// std::invalid_argument naming the bad text.
SolverKind ParseSolverKind(const std::string& text);
const char* ToString(SolverKind kind);

// A robust loss applied to loop closures only: odometry and priors are
// trusted, wrong loop closures are what robust losses are for.
struct RobustLoss {
  // kDcs: dynamic covariance scaling (Agarwal et al. 2013), the kernel made
  // for pose graphs; its width PHI is on the squared error (chi2), as in the
  // paper, not on the norm.
  enum Kind { kNone, kHuber, kCauchy, kDcs };
  Kind kind = kNone;
  double delta = 1.0;  // on the whitened residual's norm, as g2o's kernels (DCS: on chi2)
};

// Parses "none", "huber:DELTA", "cauchy:DELTA" or "dcs:PHI" (> 0); throws
// std::invalid_argument with a message naming the bad text.
RobustLoss ParseRobustLoss(const std::string& text);
std::string ToString(const RobustLoss& loss);

// Options a user tunes whatever the solver.
struct SolverOptions {
  int max_iterations = 100;
  // Worker threads; 0 means one per hardware thread.
  int threads = 0;
  // The three stopping rules are relative, so that scaling every information
  // matrix by the same factor changes neither the iterations nor the estimate.
  // Stop when the relative decrease of chi2 in one step falls below this.
  // 1e-10 rather than Ceres's 1e-6: Levenberg-Marquardt's damped steps
  // still decrease chi2 by 1e-6 of itself 1e-8 to 1e-7 above the optimum
  // (g2o's on landmark graphs, the best known on MIT and sphere2500); the
  // last digits cost one or two iterations.
  double function_tolerance = 1e-10;
  // Stop when the largest gradient component falls to this times chi2 per
  // residual (about 1 at the optimum when the information matches the
  // noise). Gauss-Newton: in the tangent space; Ceres: its projected
  // gradient, see RelativeGradientTest.
  double gradient_tolerance = 1e-10;
  // Stop when |step| <= parameter_tolerance * (|x| + parameter_tolerance).
  double parameter_tolerance = 1e-8;
  // One progress line per iteration on stderr.
  bool verbose = false;
  RobustLoss loop_closure_loss;

  // False, with *error (if not null) saying which option and why, when a
  // value is out of range; the solvers check it and throw
  // std::invalid_argument with that message.
  bool IsValid(std::string* error) const;
};

struct IterationRecord {
  int iteration = 0;
  double chi2 = 0;       // after the iteration (unchanged if the step was refused)
  double step_norm = 0;  // norm of the tangent step tried
  double time_s = 0;     // cumulative since the solver started
  bool accepted = true;  // the step was taken
  double linear_solver_time_s = 0;  // this iteration's linear solve
};

struct SolveResult {
  std::string solver;         // "ceres", "gn", ...
  std::string linear_solver;  // what factored the normal equations
  double initial_chi2 = 0, final_chi2 = 0;
  int iterations = 0;  // steps tried, accepted or not
  // Wall time of the whole solve (problem setup included) and the parts of it
  // spent linearising (Jacobians) and in the linear solver.
  double time_s = 0, setup_time_s = 0, linearize_time_s = 0, linear_solver_time_s = 0;
  // "convergence", "no_convergence" (the iteration or time limit) or "failure".
  std::string termination;
  std::string message;  // the solver's own words on why it stopped
  // One of the solver's convergence tests stopped it: the function, gradient
  // or parameter tolerance (above), or no step, however damped, lowering
  // the objective (Gauss-Newton; Ceres's smallest trust region). Never set
  // by the iteration or time limit, nor by a failure. Equivalent to
  // termination == "convergence".
  bool converged = false;
  int reused_factorizations = 0;  // Gauss-Newton: steps taken with an earlier factorisation
  // The estimate left in the graph is finite and its objective (g2o's chi2,
  // robustified when a loss is set: what the solver minimised) is no higher
  // than at the start: IsUsableEstimate. A solve that ends worse puts the
  // start back (Ceres) or never takes the step (Gauss-Newton), so this is
  // false only when the start itself is not finite. Whether it converged
  // does not matter.
  bool usable = false;
  std::vector<IterationRecord> trace;
};

// The rule for SolveResult::usable, from the objective at the start and at
// the estimate returned.
bool IsUsableEstimate(double initial_objective, double final_objective);

// Writes the result as one JSON object: the fields above (the trace as an
// array of objects), preceded by `context` (e.g. input file, sizes), whose
// values are written as JSON strings unless they parse as numbers. A number
// that is not finite is written as null, with a string "<key>_note" after it
// saying which ("not finite (inf)"): JSON has no infinity or NaN.
void WriteReportJson(const SolveResult& result, std::ostream& out,
                     const std::vector<std::pair<std::string, std::string>>& context = {});

// The one-line progress format shared by the solvers (no trailing newline).
std::string FormatIteration(const IterationRecord& record);

}  // namespace cairn
