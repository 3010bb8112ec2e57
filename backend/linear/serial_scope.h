// Keeps the threads of the libraries under the sparse Cholesky factorisation
// (CHOLMOD's OpenMP regions, OpenBLAS's workers) off while an object of this
// class lives: the factorisation runs on the calling thread alone.
//
// Why, in short (the measurements are in docs/benchmarks.md, "CHOLMOD's
// OpenMP regions"):
// - Debian's CHOLMOD opens an OpenMP region per supernode with a team size
//   fixed at its compile time, which OMP_NUM_THREADS does not change. The
//   regions only clear and copy memory, and waking their threads costs more
//   than that work.
// - OpenBLAS on more threads is no faster on a pose graph's narrow
//   supernodes, and its idle workers then spin in sched_yield, taking the
//   cores from our linearisation.
// The runtimes are found at run time (nothing is linked for this) and told
// to allow no active OpenMP level (this thread only) and one BLAS thread
// (process-wide: other threads' BLAS calls meanwhile run serially too), and
// restored afterwards. Without them this does nothing. Scopes nest.
#pragma once

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
