// What a solve reports, the same for the Ceres path and the Gauss-Newton path.
#pragma once

#include <string>
#include <vector>

namespace cairn {

struct IterationRecord {
  int iteration = 0;
  double chi2 = 0;
  double step_norm = 0;
  double time_s = 0;  // since the solve began
};

struct SolveResult {
  double initial_chi2 = 0;
  double final_chi2 = 0;
  int iterations = 0;
  double time_s = 0;
  double linearize_time_s = 0;
  double linear_solver_time_s = 0;
  std::string termination;
  bool converged = false;
  std::vector<IterationRecord> trace;
};

}  // namespace cairn
