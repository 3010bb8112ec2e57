// H dx = -b by preconditioned conjugate gradients, behind the same interface
// as the factorisations (sparse_cholesky.h), for graphs whose factor would
// not fit: H itself is all it stores, plus a preconditioner whose factor
// is bounded by a multiple of H's size.
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
// kSubgraph: that tree and the most strongly coupled of H's other blocks,
// as many as keep the subgraph's factor within `subgraph_fill` times H's
// own entries (Dellaert et al.'s subgraph preconditioning). The long
// cycles a tree cuts are what make CG slow on a pose graph; where the whole
// factor fits in the budget, the preconditioner is H and CG ends in one
// iteration.
enum class Preconditioner { kBlockJacobi, kSpanningTree, kSubgraph };

struct ConjugateGradientsOptions {
  Preconditioner preconditioner = Preconditioner::kSubgraph;
  // kSubgraph's budget: nonzeros of its factor over H's upper triangle's
  // (both in blocks). The shared 2D files' whole factors fit in 4 (city10000
  // 8,241 of its 10,684 other blocks fit in 3, and took 31 times as long as
  // with all of them, 13.9 s against 0.45 s), sphere2500's in 6.
  double subgraph_fill = 4.0;
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
