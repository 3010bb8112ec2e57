#pragma once

// Keeps the OpenMP regions of the libraries we call (CHOLMOD) on the calling
// thread while an object of this class lives.
//
// Debian's CHOLMOD opens an OpenMP region of four threads per supernode, a
// team size fixed at its compile time that OMP_NUM_THREADS does not change.
// The regions only clear and copy memory; the BLAS underneath has threads of
// its own. On two cores the threads' wake-ups cost more than the work: one
// factorisation of sphere2500 took 68-90 ms with them, 41-46 ms without.
// An OpenMP runtime found at run time is told to allow no active parallel
// level (each region then runs on the caller alone), for this thread only,
// and restored afterwards; without one this does nothing.

namespace cairn {

class SerialOpenMpScope {
 public:
  SerialOpenMpScope();
  ~SerialOpenMpScope();
  SerialOpenMpScope(const SerialOpenMpScope&) = delete;
  SerialOpenMpScope& operator=(const SerialOpenMpScope&) = delete;

 private:
  int saved_levels_ = -1;
};

}  // namespace cairn
