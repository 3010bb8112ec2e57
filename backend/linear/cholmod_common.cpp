#include "cairn/linear/cholmod_common.h"

namespace cairn {

CholmodCommon::CholmodCommon() {
  cholmod_start(&common_);
  // AMD alone: the default also tries METIS/NESDIS, which costs more in the
  // one-off analysis than it saves on pose graphs.
  common_.nmethods = 1;
  common_.method[0].ordering = CHOLMOD_AMD;
  common_.postorder = 1;
  common_.print = 0;
  // Coarser supernodes than CHOLMOD's defaults (4/16/48 columns, 80/10/5%
  // explicit zeros): a pose graph's supernodes are narrow, and BLAS runs
  // faster on fewer, larger dense blocks than the zeros cost. Measured on
  // the normal matrices of city10000 and sphere2500 (bench_gauss_newton):
  // 58 -> 37 ms and 41 -> 30 ms per factorisation, for 1.7 and 1.5 times
  // the nonzeros.
  common_.nrelax[0] = 16;
  common_.nrelax[1] = 64;
  common_.nrelax[2] = 128;
  common_.zrelax[0] = 0.8;
  common_.zrelax[1] = 0.3;
  common_.zrelax[2] = 0.1;
  common_.error_handler = nullptr;
}

CholmodCommon::~CholmodCommon() { cholmod_finish(&common_); }

}  // namespace cairn
