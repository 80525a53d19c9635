// How the particles are shared between the threads of the contact and particle passes: thread t
// takes particles [cut[t], cut[t+1]) in both (in the contact pass, the near entries they own), so
// that a thread sums the entries it evaluated itself, from its own cache. The cuts follow the
// threads' measured working times: every kEvery steps they move halfway toward the cuts that
// would have given every thread the same time (each part's cost taken as even along it). Which
// thread does a particle's work never changes its arithmetic (an owner's entries stay together,
// and every sum keeps its order), so the results are the same bits for any cuts.
#pragma once
#include <algorithm>
#include <vector>

#include "../types.hpp"

namespace tsubu::detail {

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
};

}  // namespace tsubu::detail
