// CHOLMOD's workspace (cholmod_common) with cairn's settings, started when
// made and finished when gone: the one set-up behind every CHOLMOD call
// (the factorisations, the halves, the solvers' fill estimate). Internal to
// backend/.
#pragma once

#include <cholmod.h>

namespace cairn {

class CholmodCommon {
 public:
  // cholmod_start, then AMD alone and coarser supernodes (see the .cpp).
  CholmodCommon();
  // Whatever was allocated with it must be freed first.
  ~CholmodCommon();
  CholmodCommon(const CholmodCommon&) = delete;
  CholmodCommon& operator=(const CholmodCommon&) = delete;

  // cholmod_analyze, and for a supernodal factor of more than `fine_above`
  // (exact nonzeros of L) the analysis again with CHOLMOD's own finer
  // supernodes: null when it fails. A caller that has analysed the same
  // pattern already (CHOLMOD's choice of method) gives its nonzeros as
  // `known_nonzeros`, and the supernodes are chosen before the one analysis.
  cholmod_factor* Analyze(cholmod_sparse* a, double fine_above = kFineSupernodesMinNonZeros,
                          double known_nonzeros = -1);
  static constexpr double kFineSupernodesMinNonZeros = 8e6;

  cholmod_common* get() { return &common_; }
  cholmod_common* operator->() { return &common_; }

 private:
  void SetSupernodes(bool coarse);
  cholmod_common common_;
};

}  // namespace cairn
