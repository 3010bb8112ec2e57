#include "backend/openmp_scope.h"

#include <dlfcn.h>

namespace cairn {
namespace {

// Looked up rather than linked: cairn needs no OpenMP of its own, and a
// CHOLMOD built without OpenMP brings no runtime to talk to.
struct OpenMpLevels {
  int (*get)() = nullptr;
  void (*set)(int) = nullptr;
  OpenMpLevels() {
    get = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
    set = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
    if (!get || !set) get = nullptr, set = nullptr;
  }
};

const OpenMpLevels& Levels() {
  static const OpenMpLevels levels;
  return levels;
}

}  // namespace

SerialOpenMpScope::SerialOpenMpScope() {
  const OpenMpLevels& omp = Levels();
  if (!omp.get) return;
  saved_levels_ = omp.get();
  omp.set(0);
}

SerialOpenMpScope::~SerialOpenMpScope() {
  if (saved_levels_ >= 0) Levels().set(saved_levels_);
}

}  // namespace cairn
