// A sparse LDL' factor that is modified rather than recomputed: rank
// updates and downdates A +- C C^T (CHOLMOD's cholmod_updown, which also
// grows the pattern where C brings new entries), for incremental
// optimisation, where each new measurement adds a low-rank term to the
// normal matrix. The matrix comes in its elimination order: no reordering
// is done here, so the caller's unknowns are the factor's columns. Internal
// to backend/.
#pragma once

#include <memory>
#include <vector>

struct cholmod_factor_struct;

namespace cairn {

class CholmodCommon;

class UpdatableCholesky {
 public:
  UpdatableCholesky();
  ~UpdatableCholesky();
  UpdatableCholesky(const UpdatableCholesky&) = delete;
  UpdatableCholesky& operator=(const UpdatableCholesky&) = delete;

  // Factorises the n x n symmetric matrix given by its upper triangle in
  // compressed columns (rows sorted), in the natural order. False when it
  // is not positive definite (the factor is then unusable).
  bool Factorize(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
                 const std::vector<double>& values);
  // A + C C^T (update) or A - C C^T (downdate), C n x k in compressed
  // columns with rows sorted. False when CHOLMOD fails (out of memory). A
  // downdate that leaves A indefinite is not detected here: the caller
  // checks the pivots it cares about (Pivot).
  bool Modify(bool update, int k, const std::vector<int>& col_ptr, const std::vector<int>& rows,
              const std::vector<double>& values);

  int n() const { return n_; }
  // D(j, j).
  double Pivot(int j) const { return x_[p_[j]]; }
  // Column j of L strictly below the diagonal: `count` entries, rows ascending.
  int BelowCount(int j) const { return nz_[j] - 1; }
  const int* BelowRows(int j) const { return i_ + p_[j] + 1; }
  const double* BelowValues(int j) const { return x_ + p_[j] + 1; }
  // j's parent in the elimination tree (its first row below the diagonal);
  // -1 for a root.
  int Parent(int j) const { return BelowCount(j) > 0 ? BelowRows(j)[0] : -1; }
  // Entries of L, the diagonal included.
  long NonZeros() const;

 private:
  // The factor's arrays, which CHOLMOD may move as it grows a column: taken
  // again after each change, so that the accessors above stay inline.
  void TakeArrays();
  const int* p_ = nullptr;
  const int* i_ = nullptr;
  const int* nz_ = nullptr;
  const double* x_ = nullptr;
  int n_ = 0;

  std::unique_ptr<CholmodCommon> common_;
  cholmod_factor_struct* factor_ = nullptr;
};

}  // namespace cairn
