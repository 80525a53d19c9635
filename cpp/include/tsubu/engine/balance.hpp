// How the particles are shared between the threads of the contact and particle passes: thread t
// takes particles [cut[t], cut[t+1]) in both (in the contact pass, the near entries they own), so
// that a thread sums the entries it evaluated itself, from its own cache. The cuts follow the
// threads' measured working times: every kEvery steps they move halfway toward the cuts that
// would have given every thread the same time (each part's cost taken as even along it). Which
// thread does a particle's work never changes its arithmetic (an owner's entries stay together,
// and every sum keeps its order), so the results are the same bits for any cuts.
#pragma once
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "../types.hpp"

namespace tsubu::detail {

// Where a thread needs only some other threads to have reached a point (the fused pass: its
// owners' partners moved), it waits for their posts instead of a barrier of the whole team, so
// that a slow thread holds up only the threads that read its particles. Each parallel region
// that uses them posts a new round number: no flag is ever reset.
class Signals {
 public:
  // Outside the parallel region, before it: the round its posts carry (t < nt).
  std::uint64_t open(int nt) {
    if (nt > size_) flags_.reset(new Flag[std::size_t(nt)]), size_ = nt;
    return ++round_;
  }
  void post(int t, std::uint64_t round) { flags_[t].round.store(round, std::memory_order_release); }
  // Until thread s has posted `round`: spins (the threads are pinned, a core each), then, should
  // the team outnumber the cores, yields to the thread it waits for.
  void wait(int s, std::uint64_t round) const {
    for (long spin = 0; flags_[s].round.load(std::memory_order_acquire) < round; ++spin) {
      if (spin < kSpins) relax();
      else std::this_thread::yield();
    }
  }

 private:
  static constexpr long kSpins = 1L << 12;
  static void relax() {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
  struct alignas(64) Flag {  // (a cache line each: a post does not disturb the other flags' readers)
    std::atomic<std::uint64_t> round{0};
  };
  std::unique_ptr<Flag[]> flags_;
  int size_ = 0;
  std::uint64_t round_ = 0;
};

class Balance {
 public:
  static constexpr long kEvery = 8;

  // The cuts for n particles and nt threads: the last ones, fitted to n, or even parts.
  const Index* cuts(Index n, int nt) {
    if (int(cut_.size()) != nt + 1 || cut_.back() != n) {
      if (int(cut_.size()) == nt + 1 && cut_.back() > 0) {  // spheres added or removed: rescale
        const double scale = double(n) / double(cut_.back());
        for (Index& c : cut_) c = Index(double(c) * scale);
      } else {
        cut_.assign(nt + 1, 0);
        for (int t = 0; t <= nt; ++t) cut_[t] = Index(std::int64_t(n) * t / nt);
      }
      cut_.front() = 0, cut_.back() = n;
      for (int t = 1; t < nt; ++t) cut_[t] = std::clamp(cut_[t], cut_[t - 1], n);
      busy_.assign(nt, 0.0);
      steps_ = 0;
    }
    return cut_.data();
  }

  // Thread t worked `seconds` on its part (called by the team's threads, each for itself).
  void add(int t, double seconds) {
    if (t < int(busy_.size())) busy_[t] += seconds;
  }

  // The threads' signals to each other (Signals).
  Signals& signals() { return signals_; }

  // After a step (outside the parallel regions): moves the cuts every kEvery steps.
  void step() {
    if (++steps_ < kEvery) return;
    steps_ = 0;
    const int nt = int(busy_.size());
    double total = 0;
    for (double b : busy_) total += b;
    if (nt > 1 && total > 0) {
      // Cumulative cost at each cut, then the particle where it reaches t / nt of the total.
      std::vector<Index>& old = scratch_;
      old.assign(cut_.begin(), cut_.end());
      int part = 0;
      double below = 0;  // cost of the parts before `part`
      for (int t = 1; t < nt; ++t) {
        const double goal = total * t / nt;
        while (part < nt - 1 && below + busy_[part] < goal) below += busy_[part++];
        const Index len = old[part + 1] - old[part];
        const double into = busy_[part] > 0 ? (goal - below) / busy_[part] : 0.5;
        const Index target = old[part] + Index(std::clamp(into, 0.0, 1.0) * double(len));
        cut_[t] = old[t] + (target - old[t]) / 2;
      }
      for (int t = 1; t < nt; ++t) cut_[t] = std::clamp(cut_[t], cut_[t - 1], cut_.back());
    }
    std::fill(busy_.begin(), busy_.end(), 0.0);
  }

 private:
  std::vector<Index> cut_, scratch_;
  std::vector<double> busy_;
  long steps_ = 0;
  Signals signals_;
};

}  // namespace tsubu::detail
