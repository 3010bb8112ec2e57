#include "cairn/linear/sparse_qr.h"

#include <SuiteSparseQR.hpp>

#include <algorithm>
#include <new>
#include <stdexcept>

namespace cairn {

// SuiteSparseQR works on CHOLMOD's long-integer matrices, with a workspace
// of its own (cholmod_l_start), apart from the factorisations' int one.
struct SparseQR::Impl {
  Impl() { cholmod_l_start(&cc); }
  ~Impl() {
    if (qr) SuiteSparseQR_free<double>(&qr, &cc);
    if (a) cholmod_l_free_sparse(&a, &cc);
    for (cholmod_dense** d : {&rhs_m, &rhs_n}) cholmod_l_free_dense(d, &cc);
    cholmod_l_finish(&cc);
  }
  // The first `count` entries of a dense result copied to `out`, and the
  // result freed (null: SuiteSparseQR ran out of memory).
  void Take(cholmod_dense* d, int count, double* out) {
    if (!d) throw std::bad_alloc();
    const double* v = static_cast<const double*>(d->x);
    std::copy(v, v + count, out);
    cholmod_l_free_dense(&d, &cc);
  }

  cholmod_common cc;
  cholmod_sparse* a = nullptr;
  SuiteSparseQR_factorization<double>* qr = nullptr;
  cholmod_dense *rhs_m = nullptr, *rhs_n = nullptr;
  int m = 0, n = 0;
  long factor_nonzeros = 0;
};

SparseQR::SparseQR() : impl_(std::make_unique<Impl>()) {}
SparseQR::~SparseQR() = default;

void SparseQR::Analyze(int m, int n, const std::vector<int>& col_ptr, const std::vector<int>& rows) {
  Impl& s = *impl_;
  if (m < n) throw std::invalid_argument("sparse QR: fewer rows than columns");
  s.m = m;
  s.n = n;
  s.a = cholmod_l_allocate_sparse(m, n, rows.size(), /*sorted=*/1, /*packed=*/1, /*stype=*/0,
                                  CHOLMOD_REAL, &s.cc);
  s.rhs_m = cholmod_l_zeros(m, 1, CHOLMOD_REAL, &s.cc);
  s.rhs_n = cholmod_l_zeros(n, 1, CHOLMOD_REAL, &s.cc);
  if (!s.a || !s.rhs_m || !s.rhs_n) throw std::bad_alloc();
  auto* p = static_cast<SuiteSparse_long*>(s.a->p);
  auto* i = static_cast<SuiteSparse_long*>(s.a->i);
  std::copy(col_ptr.begin(), col_ptr.end(), p);
  std::copy(rows.begin(), rows.end(), i);
  std::fill_n(static_cast<double*>(s.a->x), rows.size(), 0.0);
  // No rank detection: a column it judged negligible would be dropped from
  // the step silently; a singular system shows as a non-finite step instead.
  s.qr = SuiteSparseQR_symbolic<double>(SPQR_ORDERING_DEFAULT, /*allow_tol=*/0, s.a, &s.cc);
  if (!s.qr) throw std::bad_alloc();
}

double* SparseQR::values() { return static_cast<double*>(impl_->a->x); }

bool SparseQR::Factorize() {
  Impl& s = *impl_;
  if (!SuiteSparseQR_numeric<double>(SPQR_NO_TOL, s.a, s.qr, &s.cc)) return false;
  s.factor_nonzeros = static_cast<long>(s.cc.SPQR_istat[0] + s.cc.SPQR_istat[1]);
  return true;
}

void SparseQR::SolveLeastSquares(const double* b, double* x) {
  Impl& s = *impl_;
  std::copy(b, b + s.m, static_cast<double*>(s.rhs_m->x));
  cholmod_dense* qtb = SuiteSparseQR_qmult<double>(SPQR_QTX, s.qr, s.rhs_m, &s.cc);
  if (!qtb) throw std::bad_alloc();
  // x = E (R \ (Q^T b)), R's first n rows.
  cholmod_dense* solution = SuiteSparseQR_solve<double>(SPQR_RETX_EQUALS_B, s.qr, qtb, &s.cc);
  cholmod_l_free_dense(&qtb, &s.cc);
  s.Take(solution, s.n, x);
}

void SparseQR::SolveNormal(const double* g, double* x) {
  Impl& s = *impl_;
  std::copy(g, g + s.n, static_cast<double*>(s.rhs_n->x));
  // A E = Q R, so A^T A = E R^T R E^T: y = R^T \ (E^T g), then x = E (R \ y).
  cholmod_dense* y = SuiteSparseQR_solve<double>(SPQR_RTX_EQUALS_ETB, s.qr, s.rhs_n, &s.cc);
  if (!y) throw std::bad_alloc();
  cholmod_dense* solution = SuiteSparseQR_solve<double>(SPQR_RETX_EQUALS_B, s.qr, y, &s.cc);
  cholmod_l_free_dense(&y, &s.cc);
  s.Take(solution, s.n, x);
}

long SparseQR::FactorNonZeros() const { return impl_->factor_nonzeros; }

}  // namespace cairn
