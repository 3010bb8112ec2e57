// Which sparse Cholesky factorisation the Gauss-Newton path solves
// H dx = -b with. The factorisations themselves live in backend/linear
// (internal); this is the choice a caller makes.
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
};

// Parses the names `--linear-solver` takes; throws std::invalid_argument,
// listing them, for any other.
CholeskyKind ParseCholeskyKind(const std::string& name);
const char* ToString(CholeskyKind kind);

// kAuto made concrete for a solver with `threads` threads: with two or more,
// kTwoHalves, which splits a large graph in two halves factorised at once
// and leaves a small one (or one that splits badly) to one factorisation;
// with one, kSupernodalOrSimplicial, which picks the faster method on every
// shared file (simplicial for intel, MIT and manhattan, supernodal for
// city10000 and the 3D files; docs/benchmarks.md). Other kinds are returned
// as given.
CholeskyKind ResolveCholeskyKind(CholeskyKind kind, int threads);

}  // namespace cairn
