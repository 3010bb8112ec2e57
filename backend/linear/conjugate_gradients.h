// H dx = -b by preconditioned conjugate gradients, behind the same interface
// as the factorisations (sparse_cholesky.h), for graphs whose factor would
// not fit: H itself is all it stores, plus a preconditioner with no fill.
// Internal to backend/.
#pragma once

#include <memory>

#include "cairn/linear/sparse_cholesky.h"

namespace cairn {

// kBlockJacobi: the inverse of H's diagonal blocks (one per pose).
// kSpanningTree: H on a maximum spanning tree of its block graph (weights:
// each off-diagonal block's norm relative to its two diagonal blocks'),
// with every diagonal block kept whole, factorised exactly: a tree has no
// fill. It is positive definite whenever H is and every residual joins at
// most two blocks (dropping an edge's off-diagonal block leaves two
// positive semi-definite diagonal parts); if its factorisation fails all
// the same, block-Jacobi is used instead.
enum class Preconditioner { kBlockJacobi, kSpanningTree };

struct ConjugateGradientsOptions {
  Preconditioner preconditioner = Preconditioner::kSpanningTree;
  // Stops once an iteration lowers the quadratic model by less than this
  // share of what all of them have lowered it, times the iteration count
  // (Nash and Sofer's test, as Ceres's inner iterations use), or once the
  // residual falls to 1e-14 of |b|. Tight, so that Gauss-Newton on it ends
  // at the optimum Cholesky reaches (each step leaves at most about this
  // share of the model's decrease behind).
  double tolerance = 1e-10;
  int max_iterations = 0;  // 0: the dimension of H
};

std::unique_ptr<SparseCholesky> CreateConjugateGradients(const ConjugateGradientsOptions& options = {});

}  // namespace cairn
