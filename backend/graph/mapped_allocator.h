// An allocator whose large blocks (128 KiB and up) are mapped from the
// system on their own and unmapped when freed, whatever glibc's mmap
// threshold has become: a graph's edge arrays, and a reader's pending
// edges freed chunk by chunk as they move into the graph, go back to the
// system at once instead of staying resident in the heap.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <new>

namespace cairn {

template <typename T>
struct MappedAllocator {
  using value_type = T;
  static constexpr size_t kMappedBytes = size_t{128} << 10;

  MappedAllocator() = default;
  template <typename U>
  MappedAllocator(const MappedAllocator<U>&) {}  // NOLINT: converts as std::allocator does

  T* allocate(size_t n) {
    const size_t bytes = n * sizeof(T);
    if (bytes < kMappedBytes) return static_cast<T*>(::operator new(bytes));
    void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t n) {
    const size_t bytes = n * sizeof(T);
    if (bytes < kMappedBytes) {
      ::operator delete(p);
    } else {
      munmap(p, bytes);
    }
  }
  template <typename U>
  bool operator==(const MappedAllocator<U>&) const { return true; }
  template <typename U>
  bool operator!=(const MappedAllocator<U>&) const { return false; }
};

}  // namespace cairn
