// A small pool of persistent worker threads for the solver's inner loops:
// threads are made once per solve, not once per iteration.
#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace cairn {

class ThreadPool {
 public:
  // threads <= 1 runs everything on the calling thread.
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }
  static constexpr size_t kMinItemsPerThread = 256;
  // Calls fn(begin, end) on contiguous chunks covering [0, n), one chunk per
  // thread, the caller's thread included; returns when all are done. Loops
  // of fewer than min_items_per_thread items a thread stay on the caller's.
  void ParallelFor(size_t n, const std::function<void(size_t, size_t)>& fn,
                   size_t min_items_per_thread = kMinItemsPerThread);

 private:
  void Work(int index);

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  const std::function<void(size_t, size_t)>* task_ = nullptr;
  size_t n_ = 0;
  long generation_ = 0;
  int pending_ = 0;
  bool stop_ = false;
};

}  // namespace cairn
