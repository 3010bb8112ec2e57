#pragma once

// Keeps the threads of the libraries under the sparse Cholesky factorisation
// (CHOLMOD's OpenMP regions, OpenBLAS's workers) off while an object of this
// class lives: the factorisation runs on the calling thread alone.
//
// Both measured on 2-core machines, on the normal matrices of city10000 and
// sphere2500 (docs/benchmarks.md):
// - Debian's CHOLMOD opens an OpenMP region of four threads per supernode, a
//   team size fixed at its compile time that OMP_NUM_THREADS does not change.
//   The regions only clear and copy memory, and the threads' wake-ups cost
//   more than the work: one factorisation of sphere2500 took 68-90 ms with
//   them, 41-46 ms without.
// - OpenBLAS on two threads is no faster on a pose graph's narrow supernodes
//   (37.0 against 39.7 ms on city10000), and its idle worker then spins in
//   sched_yield, taking the second core from our linearisation.
// The runtimes are found at run time (nothing is linked for this) and told
// to allow no active OpenMP level (this thread only) and one BLAS thread
// (process-wide: other threads' BLAS calls meanwhile run serially too), and
// restored afterwards. Without them this does nothing. Scopes nest.

namespace cairn {

class SerialLinearAlgebraScope {
 public:
  SerialLinearAlgebraScope();
  ~SerialLinearAlgebraScope();
  SerialLinearAlgebraScope(const SerialLinearAlgebraScope&) = delete;
  SerialLinearAlgebraScope& operator=(const SerialLinearAlgebraScope&) = delete;

 private:
  int saved_levels_ = -1;
  int saved_blas_threads_ = -1;
};

}  // namespace cairn
