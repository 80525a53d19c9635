// Tests of the engine's array storage: large arrays are mapped aligned to 2 MiB (so that the
// kernel can back them with huge pages), small ones come from operator new, and both behave as
// ordinary vectors through growth, copies and release.
#include <cstdint>
#include <numeric>

#include "check.hpp"
#include "tsubu/memory.hpp"

using namespace tsubu;

namespace {

// Within the first 4 KiB of a huge page (each array starts a few cache lines in).
bool aligned_to_large_page(const void* p) {
  return reinterpret_cast<std::uintptr_t>(p) % detail::kLargePage < 4096;
}

std::uintptr_t colour_of(const void* p) { return reinterpret_cast<std::uintptr_t>(p) % 4096; }

void test_large_arrays_are_aligned() {
  Array<double> a(detail::kLargePage / sizeof(double) + 7, 1.5);  // just over 2 MiB, odd tail
  CHECK(aligned_to_large_page(a.data()));
  CHECK(a.front() == 1.5 && a.back() == 1.5);
  a.back() = 2.0;  // the tail beyond the last whole large page is writable
  CHECK(a.back() == 2.0);
  Array<double> b(a.size()), c(a.size());  // consecutive arrays start in different cache sets
  CHECK(colour_of(b.data()) % 64 == 0 && colour_of(b.data()) != colour_of(c.data()));
}

void test_growth_keeps_values() {
  Array<std::int32_t> a;
  for (std::int32_t k = 0; k < 3'000'000; ++k) a.push_back(k);  // crosses the 2 MiB threshold
  CHECK(aligned_to_large_page(a.data()));
  bool ok = true;
  for (std::int32_t k = 0; k < 3'000'000; ++k) ok = ok && a[k] == k;
  CHECK(ok);
  Array<std::int32_t> b = a;  // a copy gets its own mapping
  CHECK(b.data() != a.data() && b == a);
  a.clear();
  a.shrink_to_fit();  // small again: released
  CHECK(a.capacity() == 0 && b.size() == 3'000'000);
}

void test_small_arrays() {
  Array<double> a(100);
  std::iota(a.begin(), a.end(), 0.0);
  CHECK(a[99] == 99.0);
  Array<double> empty;
  CHECK(empty.data() == nullptr);
}

}  // namespace

int main() {
  test_large_arrays_are_aligned();
  test_growth_keeps_values();
  test_small_arrays();
  return tsubu_test::finish("test_memory");
}
