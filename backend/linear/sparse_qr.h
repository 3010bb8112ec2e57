// Linear least squares min |A x - b| by SuiteSparseQR's sparse QR of A
// itself, with a fixed pattern: the symbolic analysis once, then numeric
// factorisations. Gauss-Newton's step solved this way (A the whitened
// Jacobian, with rows for the damping) never forms J^T J, whose condition
// number is the square of J's. Internal to backend/.
#pragma once

#include <memory>
#include <vector>

namespace cairn {

class SparseQR {
 public:
  SparseQR();
  ~SparseQR();
  SparseQR(const SparseQR&) = delete;
  SparseQR& operator=(const SparseQR&) = delete;

  // The pattern of the m x n matrix A (m >= n) in compressed columns, rows
  // sorted within each column. Called once; A's values are then written
  // into values(), in the order of `rows`.
  void Analyze(int m, int n, const std::vector<int>& col_ptr, const std::vector<int>& rows);
  double* values();
  // A = Q R with the current values; false when SuiteSparseQR fails (out of
  // memory) or R has a zero on its diagonal (A is rank deficient).
  bool Factorize();
  // x = argmin |A x - b| (b: m entries, x: n), from the last factorisation.
  void SolveLeastSquares(const double* b, double* x);
  // x = (A^T A)^-1 g (g, x: n entries) by R alone: R^T R x = g. What a step
  // with an earlier factorisation and a new gradient needs.
  void SolveNormal(const double* g, double* x);
  // Nonzeros of R and of the Householder vectors (after Factorize).
  long FactorNonZeros() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn
