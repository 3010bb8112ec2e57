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

  cholmod_common* get() { return &common_; }
  cholmod_common* operator->() { return &common_; }

 private:
  cholmod_common common_;
};

}  // namespace cairn
