#include "tsubu/memory.hpp"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#if defined(__linux__)
#include <sys/mman.h>
#endif
#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

namespace tsubu::detail {

namespace {
constexpr std::size_t kPage = 4096;
std::size_t round_up(std::size_t a, std::size_t to) { return (a + to - 1) / to * to; }

// Arrays that all began on a huge page would put element k of every array in the same cache
// set (huge pages are contiguous in physical memory), and the step reads x[k], v[k], w[k], ...
// together: each array starts instead a different number of cache lines (0-63) into its
// mapping.
constexpr std::size_t kLine = 64, kColours = 64;
std::size_t colour() {
  static std::atomic<unsigned> next{0};
  return (next.fetch_add(7, std::memory_order_relaxed) % kColours) * kLine;
}
std::size_t mapped_length(std::size_t bytes) { return round_up(bytes + (kColours - 1) * kLine, kPage); }
}  // namespace

#if defined(__linux__)
void* map_large(std::size_t bytes) {
  const std::size_t length = mapped_length(bytes), reserve = length + kLargePage;
  void* base = mmap(nullptr, reserve, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (base == MAP_FAILED) throw std::bad_alloc();
  const auto start = reinterpret_cast<std::uintptr_t>(base);
  const std::uintptr_t aligned = round_up(start, kLargePage);
  // Give back the unaligned head and the tail beyond the array.
  if (aligned > start) munmap(base, aligned - start);
  const std::uintptr_t end = aligned + length, reserve_end = start + reserve;
  if (reserve_end > end) munmap(reinterpret_cast<void*>(end), reserve_end - end);
  madvise(reinterpret_cast<void*>(aligned), length, MADV_HUGEPAGE);  // a hint only
  return reinterpret_cast<void*>(aligned + colour());
}

void unmap_large(void* p, std::size_t bytes) {
  const auto at = reinterpret_cast<std::uintptr_t>(p);
  munmap(reinterpret_cast<void*>(at - at % kLargePage), mapped_length(bytes));
}
#else
void* map_large(std::size_t bytes) {
  void* p = std::aligned_alloc(kLargePage, round_up(bytes, kLargePage));
  if (!p) throw std::bad_alloc();
  return p;
}

void unmap_large(void* p, std::size_t) { std::free(p); }
#endif

void touch_pages(void* p, std::size_t bytes, int threads) {
  auto* const first = static_cast<unsigned char*>(p);
  const long pages = static_cast<long>((bytes + kPage - 1) / kPage);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (long k = 0; k < pages; ++k) first[k * static_cast<long>(kPage)] = 0;
}

}  // namespace tsubu::detail

namespace tsubu {

namespace {
// The first number in a file (0 when absent or not a number, e.g. cgroup's "max").
std::size_t read_number(const char* path, const std::string& key = "") {
  std::ifstream in(path);
  std::string word;
  while (in >> word) {
    if (!key.empty() && word != key) continue;
    if (!key.empty() && !(in >> word)) return 0;
    try {
      return static_cast<std::size_t>(std::stoull(word));
    } catch (...) {
      return 0;
    }
  }
  return 0;
}
}  // namespace

std::size_t available_memory() {
  std::size_t bytes = std::numeric_limits<std::size_t>::max();
#if defined(__linux__)
  if (const std::size_t kib = read_number("/proc/meminfo", "MemAvailable:")) bytes = kib * 1024;
  const std::size_t limit = read_number("/sys/fs/cgroup/memory.max");  // cgroup v2
  const std::size_t used = read_number("/sys/fs/cgroup/memory.current");
  if (limit > 0) bytes = std::min(bytes, limit > used ? limit - used : 0);
#elif defined(_SC_PHYS_PAGES)
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && page > 0) bytes = static_cast<std::size_t>(pages) * static_cast<std::size_t>(page);
#endif
  return bytes;
}

}  // namespace tsubu
