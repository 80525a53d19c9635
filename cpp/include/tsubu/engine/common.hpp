// What every part of the engine shares: the features a law switches on, and small named helpers
// for the tricks that keep the hot loops free of branches.
#pragma once
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "../contact/law.hpp"
#include "../types.hpp"
#include "world.hpp"

namespace tsubu::detail {

// What the loop must do for a law, decided at compile time.
template <class Law>
struct Features {
  static constexpr bool kHistory = Law::has_history;
  static constexpr bool kTorque = Law::has_torque;
  static constexpr bool kTangential = Law::tangential::enabled;
  static constexpr bool kRolling = Law::rolling::enabled;
  static constexpr bool kRough = Law::roughness::enabled;
  static constexpr int kRoughWidth = Law::roughness::state_width;
  // Laws without rolling friction or roughness evaluate pairs a block at a time (block.hpp).
  static constexpr bool kBlocked = !kRolling && !kRough;
};

// ---- tricks, named -------------------------------------------------------------------------
// x * 0 is 0 for any finite x and NaN for inf or NaN: summing these flags a non-finite value
// anywhere in a loop without a branch per element.
TSUBU_INLINE double nonfinite_flag(double x) { return x * 0.0; }

// Requests the cache line holding *a. gcc takes __builtin_prefetch for a call without effects:
// a loop (or a function) of nothing but prefetches is deleted outright, so those are written
// as an instruction it must keep.
template <class T>
TSUBU_INLINE void request(const T* a) {
#if defined(__x86_64__) || defined(__i386__)
  asm volatile("prefetcht0 %0" : : "m"(*reinterpret_cast<const char*>(a)));
#else
  __builtin_prefetch(a);
#endif
}
// Whether x is finite, as arithmetic (inf - inf and NaN - NaN are NaN); std::isfinite and
// Eigen's allFinite() are calls that keep the loop from vectorising.
TSUBU_INLINE bool is_finite(double x) { return x - x == 0; }
// Doubles >= 0 order as their bit patterns do as unsigned integers, and an integer maximum
// vectorises where a floating one (with its NaN rules) does not: maxima are kept on the bits.
TSUBU_INLINE std::uint64_t order_bits(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}
TSUBU_INLINE double from_order_bits(std::uint64_t b) {
  double x;
  std::memcpy(&x, &b, sizeof x);
  return x;
}

// Flags particle k as having a contact this step (threads may flag the same one).
inline void mark(std::uint8_t* loaded, Index k) { __atomic_store_n(loaded + k, 1, __ATOMIC_RELAXED); }

// Inside a parallel region: this thread's number, the team's size and its part [lo, hi) of n
// particles (contiguous, in order of thread number).
struct Share {
  int t, nt;
  Index lo, hi;
};
inline Share share(Index n) {
#ifdef _OPENMP
  const int t = omp_get_thread_num(), nt = omp_get_num_threads();
#else
  const int t = 0, nt = 1;
#endif
  return {t, nt, Index(std::int64_t(n) * t / nt), Index(std::int64_t(n) * (t + 1) / nt)};
}

// Times one parallel region into its RegionTimes: made before the region, each thread adds its
// working time (a Stopwatch, which leaves out the barriers inside) with done(), close() after
// the region. About 20 ns a thread per region.
class RegionClock {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr int kThreads = 256;  // threads beyond these are not counted in the mean
  explicit RegionClock(RegionTimes& sink) : sink_(sink), start_(Clock::now()) {}
  struct Stopwatch {
    Clock::time_point from = Clock::now();
    double busy = 0;
    void stop() { busy += std::chrono::duration<double>(Clock::now() - from).count(); }
    void start() { from = Clock::now(); }
  };
  void done(const Stopwatch& w, int t, int nt) {
    if (t < kThreads) busy_[t] = w.busy;
    if (t == 0) threads_ = std::min(nt, kThreads);
  }
  // The same, and the time counts toward thread t's part in `parts`.
  void done(const Stopwatch& w, int t, int nt, Balance& parts) {
    done(w, t, nt);
    parts.add(t, w.busy);
  }
  void close() {
    double slowest = 0, sum = 0;
    for (int t = 0; t < threads_; ++t) slowest = std::max(slowest, busy_[t]), sum += busy_[t];
    sink_.wall += std::chrono::duration<double>(Clock::now() - start_).count();
    sink_.slowest += slowest;
    sink_.mean += threads_ > 0 ? sum / threads_ : 0;
    ++sink_.count;
  }

 private:
  RegionTimes& sink_;
  Clock::time_point start_;
  int threads_ = 0;
  double busy_[kThreads];
};

// This thread's part [lo, hi) of the particles in the contact and particle passes: the
// balanced cuts (balance.hpp) planned for `planned` threads, or even parts if the team has
// another size.
inline Share share(Index n, const Index* cut, int planned) {
  Share me = share(n);
  if (me.nt == planned) me.lo = cut[me.t], me.hi = cut[me.t + 1];
  return me;
}
// Where part s of a team of nt starts (s = nt: n), as share() cuts.
inline Index part_begin(Index n, const Index* cut, int planned, int nt, int s) {
  return nt == planned ? cut[s] : Index(std::int64_t(n) * s / nt);
}

// Scans entries [lo, hi) without branches, keeping in `act` those that pass `keep`; returns
// how many.
template <class Keep>
Index compact(Index lo, Index hi, Index* act, Keep&& keep) {
  Index count = 0;
  for (Index q = lo; q < hi; ++q) {
    act[count] = q;
    count += keep(q) ? 1 : 0;
  }
  return count;
}

// What evaluating contacts found, for one thread or reduced over all: the largest overlap
// beyond max_overlap x the smaller radius, whether a result is not finite, and the largest
// |fx| + |fy| + |fz| of a contact force (for the fused pass's bound).
struct Found {
  double excess = 0, fmax = 0;
  int bad = 0;
};

}  // namespace tsubu::detail
