// The fused pass (large scenes): the particle pass of this step and the pairs of the next step's
// contact pass in one sweep over the particles, so that the contacts find their particles in
// cache instead of memory. A pair owned by particle i is evaluated as soon as every particle
// within the near list's reach of i has moved; owners whose partners lie in another thread's
// part wait for that thread's post (Signals), not for the whole team; each thread's walls
// follow its pairs, as in the contact pass. The same arithmetic on the same entries as the two
// passes, in the same order per owner: the same bits.
// Only for steps after which no neighbour list can be due (Stepper::fusable).
#pragma once
#include <algorithm>

#include "contact_pass.hpp"
#include "particle_pass.hpp"

namespace tsubu::detail {

template <class Law>
struct FusedPass {
  using CP = ContactPass<Law>;
  using PP = ParticlePass<Law>;

  // `below`, `above`: how far down and up the particle array a near pair's partner lies from its
  // owner. Returns true if a new velocity is not finite; sets vmax2 to max |v|^2 and `next` to
  // the next step's findings.
  // `cut`: the threads' parts of the particles (balance.hpp).
  static bool run(const ParticleView& pv, const ContactView& c, Index below, Index above,
                  const Index* cut, Balance& parts, double& vmax2_out, Found& next, RegionTimes& times) {
    const Index n = pv.n;
    const Index* owned = c.owned;
    double vmax2 = 0, check = 0, excess = 0, fmax = 0, rel2 = 0;  // (rel2: never periodic)
    int bad = 0;
    Signals& moved = parts.signals();
    const std::uint64_t round = moved.open(pv.threads);
    RegionClock clock(times);
#pragma omp parallel num_threads(pv.threads) reduction(max : vmax2, excess, fmax, bad) \
    reduction(+ : check)
    {
      RegionClock::Stopwatch work;
      const auto [t, nt, lo, hi] = share(n, cut, pv.threads);
      auto begin = [&, nt = nt](int s) { return part_begin(n, cut, pv.threads, nt, s); };
      // Owners in [ilo, ihi) have all their partners in [lo, hi).
      const Index ilo = t == 0 ? lo : std::min(hi, lo + below);
      const Index ihi = t == nt - 1 ? hi : std::max(ilo, hi - above);
      // Other threads' owners reach [lo, elo) and [ehi, hi): these move first, and the thread
      // posts that they have, so that those owners seldom wait.
      const Index elo = t == 0 ? lo : std::min(hi, lo + above);
      const Index ehi = t == nt - 1 ? hi : std::max(elo, hi - below);
      auto move = [&](Index from, Index to) {
        Index b = pv.first_busy(from);
        for (Index c0 = from; c0 < to; c0 += PP::kChunk)
          PP::chunk(pv, c0, std::min(to, c0 + PP::kChunk), b, vmax2, rel2, check);
      };
      move(lo, elo);
      move(ehi, hi);
      moved.post(t, round);
      Scan scan{};
      typename CP::Block block(c.same);
      Found f;
      Index b = pv.first_busy(elo), done = ilo;  // owners [ilo, done) evaluated
      for (Index c0 = elo; c0 < ehi; c0 += PP::kChunk) {
        const Index c1 = std::min(ehi, c0 + PP::kChunk);
        PP::chunk(pv, c0, c1, b, vmax2, rel2, check);
        const Index ready = std::min(ihi, c1 - above);  // every partner of an owner below has moved
        if (ready > done) {
          CP::pair_range(c, owned[done], owned[ready], scan, block, f);
          done = ready;
        }
      }
      CP::pair_range(c, owned[done], owned[ihi], scan, block, f);
      // The owners whose partners other threads move, once those threads have posted. (Where
      // a part is shorter than the reach, an owner of [lo, ilo) may reach past hi too, and
      // beyond the next thread's part.)
      work.stop();
      for (int s = t - 1; s >= 0 && begin(s + 1) > lo - below; --s) moved.wait(s, round);
      for (int s = t + 1; s < nt && begin(s) < hi + above; ++s) moved.wait(s, round);
      work.start();
      CP::pair_range(c, owned[lo], owned[ilo], scan, block, f);
      CP::pair_range(c, owned[ihi], owned[hi], scan, block, f);
      CP::wall_part(c, lo, hi, scan, block, f);
      excess = f.excess, fmax = f.fmax, bad = f.bad;
      work.stop();
      clock.done(work, t, nt, parts);
    }
    clock.close();
    vmax2_out = vmax2;
    next = {excess, fmax, bad};
    return !(check == 0);
  }
};

}  // namespace tsubu::detail
