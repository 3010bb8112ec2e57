// Sparse Cholesky with a fixed pattern: the symbolic analysis (fill-reducing
// ordering) once, then only numeric factorisations, as Gauss-Newton needs.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cairn {

// One factorisation of the whole matrix: SuiteSparse's supernodal or
// simplicial method, SuiteSparse choosing between them per matrix by flops
// per nonzero, or Eigen's simplicial LDLT. (The two-halves factorisation is
// CreateDomainCholesky in domain_cholesky.h; solvers/linear_solver.h's
// CholeskyKind is the caller's choice among all of them.)
enum class Factorization { kSupernodal, kSimplicial, kSupernodalOrSimplicial, kEigenLDLT };

// Where each entry of the caller's layout lives in a factorisation's own
// storage (up to two arrays): entry k is arrays[index[k] >> 31] at
// position index[k] & 0x7fffffff.
struct ValuePlaces {
  double* arrays[2] = {nullptr, nullptr};
  std::vector<uint32_t> index;
  double& operator[](size_t k) const {
    const uint32_t t = index[k];
    return arrays[t >> 31][Position(t)];
  }
  static uint32_t Place(int array, int position) {
    return (static_cast<uint32_t>(array) << 31) | static_cast<uint32_t>(position);
  }
  static int Position(uint32_t place) { return static_cast<int>(place & 0x7fffffffu); }
};

class SparseCholesky {
 public:
  virtual ~SparseCholesky() = default;
  static std::unique_ptr<SparseCholesky> Create(Factorization kind);

  // The upper triangle of a symmetric n x n matrix in compressed columns,
  // rows sorted within each column. Called once. `block_sizes`, if not
  // empty, splits the rows into dense diagonal blocks (one per pose): the
  // fill-reducing ordering is then computed on the far smaller block graph.
  virtual void Analyze(int n, const std::vector<int>& col_ptr, const std::vector<int>& rows,
                       const std::vector<int>& block_sizes = {}) = 0;
  // For a matrix that grew: the pattern of the last Analyze (or Extend) is
  // the leading part of this one, which only adds columns (and rows) at the
  // end. Keeps the elimination order, with the new unknowns eliminated
  // last, and derives the rest of the analysis from it without any ordering
  // work. False (nothing changed) when the pattern is not such an
  // extension or the backend cannot extend: Analyze then.
  virtual bool Extend(int /*n*/, const std::vector<int>& /*col_ptr*/,
                      const std::vector<int>& /*rows*/, const std::vector<int>& /*block_sizes*/ = {}) {
    return false;
  }
  // The matrix's values, in the order of `rows`; callers write into it.
  virtual double* values() = 0;
  // Instead of values(): the caller writes each entry where the
  // factorisation reads it, and the copy of the matrix in the caller's
  // layout (and the map into its own) is freed; at a million 2D poses they
  // were 12 bytes per entry of H, 240 MB. True when the backend can; then
  // values() is no longer valid until the next Analyze or Extend, after
  // which the places must be taken again. Once per Analyze or Extend: a
  // second call returns false (the map it would need is freed).
  virtual bool TakeValuesInPlace(ValuePlaces* /*places*/) { return false; }
  // False when the matrix is not positive definite.
  virtual bool Factorize() = 0;
  // x = A^-1 b, with the last factorisation. x and b may not alias.
  virtual void Solve(const double* b, double* x) = 0;
  // Nonzeros of the factor (after the first Factorize).
  virtual long FactorNonZeros() const = 0;
  virtual bool IsSupernodal() const = 0;
  // How the last Analyze chose to factorise, for reports.
  virtual std::string Method() const { return IsSupernodal() ? "supernodal" : "simplicial"; }

  // Reusing an ordering: a block permutation (block k is eliminated at
  // position k) that the next Analyze takes instead of computing AMD (then
  // postorders on its elimination tree, as it does AMD's); empty for AMD. Lets a graph that only grew keep its old ordering with the new
  // poses appended. Backends that order internally (Eigen) ignore it.
  virtual void SetBlockOrdering(const std::vector<int>& block_perm) {}
  // The block permutation the last Analyze used; empty when unknown.
  virtual std::vector<int> BlockOrdering() const { return {}; }
};

}  // namespace cairn
