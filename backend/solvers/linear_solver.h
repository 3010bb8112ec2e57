// How the Gauss-Newton path solves H dx = -b: one of the sparse Cholesky
// factorisations, sparse QR of the whitened Jacobian, or preconditioned
// conjugate gradients. They live in backend/linear (internal); this is the
// choice a caller makes.
#pragma once

#include <string>

namespace cairn {

enum class CholeskyKind {
  kAuto,                    // cairn's choice per problem: see ResolveCholeskyKind
  kSupernodal,              // SuiteSparse, supernodal (BLAS-bound; fast with OpenBLAS)
  kSimplicial,              // SuiteSparse, simplicial (up-looking; good on small 2D graphs)
  kSupernodalOrSimplicial,  // SuiteSparse chooses per matrix by flops per nonzero
  kEigenLDLT,               // Eigen's SimplicialLDLT with AMD
  kTwoHalves,               // two halves of the graph factorised at once, then their separator
  // min |J dx + r| by SuiteSparseQR on the whitened Jacobian J itself (with
  // rows sqrt(lambda D) when damped): H is never formed, so its condition
  // number is J's, not J's squared. Slower and larger than Cholesky.
  kQR,
  // Conjugate gradients on H, preconditioned by H on a spanning tree of the
  // pose graph (factorised with no fill) or by H's diagonal blocks: memory
  // in proportion to H, for graphs whose factor would not fit.
  kConjugateGradients,
  kConjugateGradientsJacobi,
};

// Parses the names `--linear-solver` takes; throws std::invalid_argument,
// listing them, for any other.
CholeskyKind ParseCholeskyKind(const std::string& name);
const char* ToString(CholeskyKind kind);

// `--gn-factor-memory`: "auto" (-1), "unlimited" (infinity) or a number of
// MB >= 0, as bytes (GaussNewtonOptions::factor_memory_bytes); throws
// std::invalid_argument for anything else.
double ParseFactorMemory(const std::string& text);

// kAuto made concrete: kTwoHalves, whatever the thread count. It splits a
// large graph in two halves (factorised at once with two or more threads,
// one after the other with one) and leaves a small one, or one that splits
// badly, to SuiteSparse's own choice of method (simplicial for intel, MIT and
// manhattan; docs/benchmarks.md). Where it splits depends on the graph
// alone, so the estimate does not depend on `threads` to the last bit.
// Other kinds are returned as given.
CholeskyKind ResolveCholeskyKind(CholeskyKind kind, int threads);

}  // namespace cairn
