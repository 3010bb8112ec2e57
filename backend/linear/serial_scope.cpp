#include "cairn/linear/serial_scope.h"

#include <dlfcn.h>

namespace cairn {
namespace {

// Looked up rather than linked: cairn needs no OpenMP of its own, and
// another BLAS (or a CHOLMOD built without OpenMP) brings none of these.
struct Runtimes {
  int (*get_levels)() = nullptr;
  void (*set_levels)(int) = nullptr;
  int (*get_blas_threads)() = nullptr;
  void (*set_blas_threads)(int) = nullptr;
  Runtimes() {
    get_levels = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
    set_levels = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
    if (!get_levels || !set_levels) get_levels = nullptr, set_levels = nullptr;
    get_blas_threads =
        reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    set_blas_threads =
        reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    if (!get_blas_threads || !set_blas_threads) get_blas_threads = nullptr, set_blas_threads = nullptr;
  }
};

const Runtimes& Found() {
  static const Runtimes runtimes;
  return runtimes;
}

}  // namespace

SerialLinearAlgebraScope::SerialLinearAlgebraScope() {
  const Runtimes& rt = Found();
  if (rt.get_levels) {
    saved_levels_ = rt.get_levels();
    rt.set_levels(0);
  }
  if (rt.get_blas_threads) {
    saved_blas_threads_ = rt.get_blas_threads();
    if (saved_blas_threads_ != 1) rt.set_blas_threads(1);
  }
}

SerialLinearAlgebraScope::~SerialLinearAlgebraScope() {
  const Runtimes& rt = Found();
  if (saved_levels_ >= 0) rt.set_levels(saved_levels_);
  if (saved_blas_threads_ > 1) rt.set_blas_threads(saved_blas_threads_);
}

}  // namespace cairn
