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
  SetSupernodes(/*coarse=*/true);
  common_.error_handler = nullptr;
}

void CholmodCommon::SetSupernodes(bool coarse) {
  // Fine: CHOLMOD's own column counts, fewer explicit zeros in the larger
  // supernodes (5% and 1% against its 10% and 5%).
  const int nrelax[2][3] = {{4, 8, 16}, {16, 64, 128}};
  const double zrelax[2][3] = {{0.8, 0.05, 0.01}, {0.8, 0.3, 0.1}};
  for (int k = 0; k < 3; ++k) {
    common_.nrelax[k] = nrelax[coarse][k];
    common_.zrelax[k] = zrelax[coarse][k];
  }
}

// The coarse supernodes' explicit zeros cost little on the shared files'
// factors (1-3 million entries) but grow with the graph: on the simulated
// 200,000- and 1,000,000-pose 2D graphs they made the factor three times
// its exact size (m200k: 58.9 M entries for 19.3 M nonzeros; CHOLMOD's own
// settings 29.3 M), which was most of the solve's peak memory, for no
// speed (docs/benchmarks.md, "Memory"). The fine ones store 1.18 times the
// exact nonzeros of the 1 M-pose graph's halves against CHOLMOD's 1.42
// (138.7 M entries against 166.9 M for 117.8 M), at the same speed; with
// no relaxation at all (1.10) the factorisation was 13% slower.
cholmod_factor* CholmodCommon::Analyze(cholmod_sparse* a, double fine_above,
                                       double known_nonzeros) {
  cholmod_factor* factor = nullptr;
  if (known_nonzeros < 0) {
    factor = cholmod_analyze(a, &common_);
    if (!factor || !factor->is_super || common_.lnz <= fine_above) return factor;
    cholmod_free_factor(&factor, &common_);
  } else if (known_nonzeros <= fine_above) {
    return cholmod_analyze(a, &common_);
  }
  SetSupernodes(/*coarse=*/false);
  factor = cholmod_analyze(a, &common_);
  SetSupernodes(/*coarse=*/true);
  return factor;
}

CholmodCommon::~CholmodCommon() { cholmod_finish(&common_); }

}  // namespace cairn
