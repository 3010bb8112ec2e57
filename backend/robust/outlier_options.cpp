// The range checks of OutlierRejectionOptions (SolveRejectingOutliers calls
// them; so does `cairn optimize --reject-outliers` before reading its input).
#include <cmath>
#include <string>

#include "cairn/robust/outliers.h"

namespace cairn {

bool OutlierRejectionOptions::IsValid(std::string* error) const {
  const char* why = nullptr;
  if (!(confidence > 0 && confidence < 1))
    why = "confidence must lie in (0, 1)";
  else if (!(threshold_chi2 >= 0) || std::isinf(threshold_chi2))
    why = "threshold_chi2 must be a number >= 0 (0: from the confidence)";
  else if (!(mu_factor > 1))
    why = "GNC's mu_factor must exceed 1";
  else if (!(inner_tolerance >= 0 && inner_tolerance < 1))
    why = "GNC's inner_tolerance must lie in [0, 1)";
  else if (max_rounds < 1)
    why = "GNC needs at least one round (max_rounds)";
  else if (inner_iterations < 0 || consistency_window < 0 || consistency_partners < 0 ||
           group_window < 0 || threads < 0)
    why = "inner_iterations, consistency_window, consistency_partners, group_window and threads "
          "must not be negative";
  else if (!(restart_chi2_factor > 1))
    why = "restart_chi2_factor must exceed 1";
  else if (trusted_iterations < 0)
    why = "trusted_iterations must not be negative";
  else if (max_passes < 0 || max_verify_rounds < 0)
    why = "max_passes and max_verify_rounds must not be negative";
  else if (fresh_check_iterations < 0)
    why = "fresh_check_iterations must not be negative";
  else if (gnc_passes < 1)
    why = "GNC over all loop closures needs at least one pass (gnc_passes)";
  else if (!(readmit_reach >= 0) || !(readmit_tail >= 0))
    why = "readmit_reach and readmit_tail must not be negative";
  if (why && error) *error = why;
  return !why;
}

}  // namespace cairn
