// The fused pass (large scenes): the particle pass of this step and the pairs of the next step's
// contact pass in one sweep over the particles, so that the contacts find their particles in
// cache instead of memory. A pair owned by particle i is evaluated as soon as every particle
// within the near list's reach of i has moved; owners whose partners lie in another thread's
// part wait for a barrier; the walls follow all pairs, as in the contact pass. The same
// arithmetic on the same entries as the two passes, in the same order per owner: the same bits.
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
    RegionClock clock(times);
#pragma omp parallel num_threads(pv.threads) reduction(max : vmax2, excess, fmax, bad) \
    reduction(+ : check)
    {
      RegionClock::Stopwatch work;
      const auto [t, nt, lo, hi] = share(n, cut, pv.threads);
      // Owners in [ilo, ihi) have all their partners in [lo, hi).
      const Index ilo = t == 0 ? lo : std::min(hi, lo + below);
      const Index ihi = t == nt - 1 ? hi : std::max(ilo, hi - above);
      Scan scan{};
      typename CP::Block block(c.same);
      Found f;
      Index b = pv.first_busy(lo), done = ilo;  // owners [ilo, done) evaluated
      for (Index c0 = lo; c0 < hi; c0 += PP::kChunk) {
        const Index c1 = std::min(hi, c0 + PP::kChunk);
        PP::chunk(pv, c0, c1, b, vmax2, rel2, check);
        const Index ready = std::min(ihi, c1 - above);  // every partner of an owner below has moved
        if (ready > done) {
          CP::pair_range(c, owned[done], owned[ready], true, scan, block, f);
          done = ready;
        }
      }
      CP::pair_range(c, owned[done], owned[ihi], true, scan, block, f);
      work.stop();
#pragma omp barrier
      work.start();
      CP::pair_range(c, owned[lo], owned[ilo], true, scan, block, f);
      CP::pair_range(c, owned[ihi], owned[hi], true, scan, block, f);
      work.stop();
#pragma omp barrier
      work.start();
      CP::wall_part(c, t, nt, scan, block, f);
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
