// What every timed, threaded step shares: wall time since a start, and the
// rule that turns a requested thread count into an actual one.
#pragma once

#include <algorithm>
#include <chrono>
#include <thread>

namespace cairn {

// Wall-clock seconds since `since` (steady_clock: immune to clock changes).
inline double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Worker threads for a request: 0 (or less) means one per hardware thread,
// and at least one when the hardware does not say.
inline int ResolveThreads(int requested) {
  return requested > 0 ? requested
                       : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace cairn
