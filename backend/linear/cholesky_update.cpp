#include "cairn/linear/cholesky_update.h"

#include <cholmod.h>

#include "cairn/linear/cholmod_common.h"

namespace cairn {
namespace {

// A view of caller-owned compressed columns as CHOLMOD's matrix: nothing
// is copied, CHOLMOD only reads it.
cholmod_sparse View(int nrow, int ncol, const std::vector<int>& col_ptr,
                    const std::vector<int>& rows, const std::vector<double>& values, int stype) {
  cholmod_sparse a{};
  a.nrow = static_cast<size_t>(nrow);
  a.ncol = static_cast<size_t>(ncol);
  a.nzmax = rows.size();
  a.p = const_cast<int*>(col_ptr.data());
  a.i = const_cast<int*>(rows.data());
  a.x = const_cast<double*>(values.data());
  a.stype = stype;
  a.itype = CHOLMOD_INT;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
  return a;
}

}  // namespace

UpdatableCholesky::UpdatableCholesky() : common_(std::make_unique<CholmodCommon>()) {}

UpdatableCholesky::~UpdatableCholesky() {
  if (factor_) cholmod_free_factor(&factor_, common_->get());
}

void UpdatableCholesky::TakeArrays() {
  n_ = factor_ ? static_cast<int>(factor_->n) : 0;
  p_ = factor_ ? static_cast<const int*>(factor_->p) : nullptr;
  i_ = factor_ ? static_cast<const int*>(factor_->i) : nullptr;
  nz_ = factor_ ? static_cast<const int*>(factor_->nz) : nullptr;
  x_ = factor_ ? static_cast<const double*>(factor_->x) : nullptr;
}

bool UpdatableCholesky::Factorize(int n, const std::vector<int>& col_ptr,
                                  const std::vector<int>& rows,
                                  const std::vector<double>& values) {
  if (factor_) cholmod_free_factor(&factor_, common_->get());
  TakeArrays();
  // The caller's order is the elimination order (unknowns it will append
  // to are placed last by it). The supernodal method factorises it several
  // times faster than the simplicial one (3D: 6x6 blocks, dense fronts), and
  // its factor is then turned into the simplicial LDL' form that
  // cholmod_updown modifies. CHOLMOD's own relaxation: the zeros the
  // coarser supernodes of CholmodCommon add would be entries each update
  // passes.
  cholmod_common* c = common_->get();
  c->nmethods = 1;
  c->method[0].ordering = CHOLMOD_NATURAL;
  c->postorder = 0;
  c->supernodal = CHOLMOD_SUPERNODAL;
  c->nrelax[0] = 4;
  c->nrelax[1] = 16;
  c->nrelax[2] = 48;
  c->zrelax[0] = 0.8;
  c->zrelax[1] = 0.1;
  c->zrelax[2] = 0.05;
  cholmod_sparse a = View(n, n, col_ptr, rows, values, /*stype=*/1);
  factor_ = cholmod_analyze(&a, c);
  if (!factor_) return false;
  if (!cholmod_factorize(&a, factor_, c) || c->status != CHOLMOD_OK ||
      factor_->minor < factor_->n ||
      !cholmod_change_factor(CHOLMOD_REAL, /*to_ll=*/0, /*to_super=*/0, /*to_packed=*/1,
                             /*to_monotonic=*/1, factor_, c)) {
    cholmod_free_factor(&factor_, c);
    TakeArrays();
    return false;
  }
  TakeArrays();
  // LDL' goes through an indefinite matrix without complaint: its pivots say.
  for (int j = 0; j < n; ++j)
    if (!(Pivot(j) > 0)) {
      cholmod_free_factor(&factor_, common_->get());
      TakeArrays();
      return false;
    }
  return true;
}

bool UpdatableCholesky::Modify(bool update, int k, const std::vector<int>& col_ptr,
                               const std::vector<int>& rows, const std::vector<double>& values) {
  if (!factor_ || k == 0) return factor_ != nullptr;
  cholmod_sparse c = View(n(), k, col_ptr, rows, values, /*stype=*/0);
  const bool ok = cholmod_updown(update ? 1 : 0, &c, factor_, common_->get()) != 0;
  TakeArrays();
  return ok;
}

long UpdatableCholesky::NonZeros() const {
  if (!factor_) return 0;
  long nnz = 0;
  for (int j = 0; j < n_; ++j) nnz += nz_[j];
  return nnz;
}

}  // namespace cairn
