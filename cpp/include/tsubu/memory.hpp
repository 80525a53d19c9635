// Storage for the particle and contact arrays. Arrays of 2 MiB and more are mapped on their own,
// aligned to 2 MiB, and offered to the kernel's transparent huge pages (Linux, MADV_HUGEPAGE):
// at N = 1e6 the step reads partners' positions and contact entries all over tens of MiB, and
// with 4 KiB pages most of those reads also miss the TLB. Each starts 0-63 cache lines into its
// first huge page, so that element k of different arrays does not share a cache set. Smaller
// arrays come from operator new. Every array has kTail bytes allocated past its capacity, so that
// a 4-wide load of its last 3-vector (step.hpp, load4) stays inside the allocation.
#pragma once
#include <cstddef>
#include <new>
#include <vector>

namespace tsubu {

namespace detail {
constexpr std::size_t kLargePage = std::size_t(2) << 20;
constexpr std::size_t kTail = 32;
// `bytes` (>= kLargePage) less than 4 KiB past a kLargePage boundary; throws std::bad_alloc.
void* map_large(std::size_t bytes);
void unmap_large(void* p, std::size_t bytes);
// Writes a zero byte into each 4 KiB page of [p, p + bytes) on `threads` threads, so that the
// page faults of a fresh mapping (where the kernel zeroes each page) are shared between them.
void touch_pages(void* p, std::size_t bytes, int threads);
}  // namespace detail

// Bytes the process can still allocate without swapping or being killed: the kernel's
// MemAvailable, capped by the cgroup's limit less its usage (Linux); the physical memory
// elsewhere. Requests larger than this are refused up front (ResourceError).
std::size_t available_memory();

template <class T>
struct LargePageAllocator {
  using value_type = T;
  LargePageAllocator() noexcept = default;
  template <class U>
  LargePageAllocator(const LargePageAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T) + detail::kTail;
    if (bytes >= detail::kLargePage) return static_cast<T*>(detail::map_large(bytes));
    return static_cast<T*>(::operator new(bytes));
  }
  void deallocate(T* p, std::size_t n) noexcept {
    const std::size_t bytes = n * sizeof(T) + detail::kTail;
    if (bytes >= detail::kLargePage)
      detail::unmap_large(p, bytes);
    else
      ::operator delete(p);
  }
  template <class U>
  bool operator==(const LargePageAllocator<U>&) const noexcept { return true; }
  template <class U>
  bool operator!=(const LargePageAllocator<U>&) const noexcept { return false; }
};

// The engine's per-particle and per-entry arrays.
template <class T>
using Array = std::vector<T, LargePageAllocator<T>>;

}  // namespace tsubu
