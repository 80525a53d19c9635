// Pass 1 of a step: every near pair and near-wall entry in contact, or in contact at the last
// step, is evaluated (or ended) and its result stored with it; each owner books the energy its
// entries lost. A branch-free scan compacts the entries in contact, 64 at a time, so that the
// spheres it read are still in the nearest cache when they are evaluated.
#pragma once
#include <algorithm>
#include <cmath>

#include "block.hpp"
#include "mesh_contacts.hpp"

namespace tsubu::detail {

template <class Law>
struct ContactPass {
  using F = Features<Law>;
  using C = Contacts<Law>;
  using B = Blocked<Law>;
  using Block = typename B::Block;

  // The pair entries [lo, hi) in contact or in contact last step, into the scan after its
  // first `count` (0, or what the far scan's refill holds already: far_pairs); the separations
  // found on the way are kept for the law. Returns the new count.
  // kOneCut: every entry's (r_i + r_j)^2 is the one value cut2[0] (NeighborList::cut_mask).
  template <bool kOneCut>
  static Index compact_pairs(const ContactView& c, Index lo, Index hi, Scan& s, Index count = 0) {
    const double* const cut2 = c.cut2;
    const double one = kOneCut ? cut2[0] : 0.0;
    for (Index q = lo; q < hi; ++q) {
      const L3 d = lanes(Domain::displacement(vec3(c.x, c.own[q]), vec3(c.x, c.par[q])));
      const double dd = dot(d, d);
      s.act[count] = q;
      s.dx[count] = d.x, s.dy[count] = d.y, s.dz[count] = d.z, s.d2[count] = dd;
      count += ((dd < (kOneCut ? one : cut2[q])) | (c.touch[q] != 0)) ? 1 : 0;
    }
    return count;
  }

  // 1/|x_ij| of every kept pair, in one pass that the compiler vectorises: the square roots and
  // divisions then leave the contact law's critical path.
  [[gnu::noinline]] static void inverse_distances(Scan& s, Index count) {
    for (Index a = 0; a < count; ++a) s.inv[a] = 1.0 / std::sqrt(s.d2[a]);
  }

  static void note_force(const Eigen::Map<Vec3>& force, Found& f) {
    if (!is_finite(force.sum())) f.bad = 1;
    f.fmax = std::max(f.fmax, force.cwiseAbs().sum());
  }

  // Near-pair entries [lo, hi), whole owners, a chunk of kBlock at a time; from
  // ContactView::kAskPairs near pairs on, each block's data requested before its gather. (The
  // partners' positions are not requested ahead: that prefetch had been compiled away since
  // da3e6fa, and made to run it was no faster; docs/benchmarks.md, "Walls in two levels".)
  [[gnu::noinline]] static void pair_range(const ContactView& c, Index lo, Index hi, Scan& scan,
                                           Block& block, Found& f) {
    if constexpr (F::kBlocked)
      if (std::size_t(c.n) >= ContactView::kFar) return far_pairs(c, lo, hi, scan, block, f);
    for (Index base = lo; base < hi; base += kBlock) {
      const Index end = std::min<Index>(hi, base + kBlock);
      const Index count = c.cut_mask == 0 ? compact_pairs<true>(c, base, end, scan)
                                           : compact_pairs<false>(c, base, end, scan);
      if constexpr (F::kBlocked)
        if (c.ask) B::request_pairs(c, scan, count);
      inverse_distances(scan, count);
      if constexpr (F::kBlocked) {
        if (B::pairs(c, scan, int(count), block, f.excess, f.fmax)) f.bad = 1;
      } else {
        for (Index a = 0; a < count; ++a) {
          const Index q = scan.act[a];
          const double lost = C::pair(c, q, scan.inv[a], f.excess);
          if (lost != 0) c.diss[c.own[q]] += lost;
          if (c.touch[q]) {
            mark(c.loaded, c.own[q]);
            mark(c.loaded, c.par[q]);
          }
          note_force(vec3(c.force, q), f);
        }
      }
    }
  }

  // A scene too large to stay in cache (the blocked laws): the scan takes kScanStep entries at a
  // time until the block is nearly full, and the block's data is requested together before the
  // law reads it (Blocked::request_pairs). Where contacts are few among many near entries (the
  // 1e6 drop: 25,000 contacts in 400,000 entries) the blocks are still full and their misses
  // overlap; in cache, the refill cost the dense beds 1-2 % (pair_range's loop instead).
  static constexpr Index kScanStep = 16;
  [[gnu::noinline]] static void far_pairs(const ContactView& c, Index lo, Index hi, Scan& scan,
                                          Block& block, Found& f) {
    for (Index base = lo; base < hi;) {
      Index count = 0;
      do {
        const Index end = std::min<Index>(hi, base + kScanStep);
        count = c.cut_mask == 0 ? compact_pairs<true>(c, base, end, scan, count)
                                : compact_pairs<false>(c, base, end, scan, count);
        base = end;
      } while (base < hi && count <= kBlock - kScanStep);
      B::request_pairs(c, scan, count);
      inverse_distances(scan, count);
      if (B::pairs(c, scan, int(count), block, f.excess, f.fmax)) f.bad = 1;
    }
  }

  // The near-wall entries of particles [lo, hi) in contact or just released; after the pairs
  // those particles own, so that an owner's dissipation sum keeps one order.
  static void wall_part(const ContactView& c, Index lo, Index hi, Scan& scan, Block& block, Found& f) {
    const Index wlo = c.wnear_offset[lo], whi = c.wnear_offset[hi];
    if (!c.meshes) {
      wall_positions(c, wlo, whi, scan, block, f);
      return;
    }
    // With a mesh, a run of whole spheres at a time: measured (which requests each entry's
    // data a few positions ahead), then evaluated while that data is still in the nearest cache.
    for (Index a = wlo; a < whi;) {
      Index b = std::min(whi, a + kWallRun);
      if (b < whi) b = c.wnear_offset[c.wown[c.wnear[b - 1]] + 1];  // (to the end of its sphere)
      MeshContacts<Law>::measure(c, a, b);
      wall_positions(c, a, b, scan, block, f);
      a = b;
    }
  }
  static constexpr Index kWallRun = 256;

  // The near-wall positions [wlo, whi) (whole spheres; measured, where there is a mesh): those
  // in contact or just released evaluated, in order.
  static void wall_positions(const ContactView& c, Index wlo, Index whi, Scan& scan, Block& block, Found& f) {
    Index* const wact = c.wact;
    auto in_contact = [&](Index p) {
      const Index e = c.wnear[p];
      const Wall& P = wall_plane(c, e);
      const double gap = P.distance(vec3(c.x, c.wown[e])) - c.r[c.wown[e] & c.cut_mask];
      return (gap < 0) | (c.wtouch[e] != 0);
    };
    // (Where the measure held a triangle clear, its plane is not read: most of a fine mesh's.)
    const Index wcount = c.clear ? compact(wlo, whi, wact + wlo, [&](Index p) {
      return !c.clear[c.wnear[p]].held && in_contact(p);
    }) : compact(wlo, whi, wact + wlo, in_contact);
    if constexpr (F::kBlocked) {
      Index e[kBlock];
      for (Index a0 = 0; a0 < wcount; a0 += kBlock) {
        const int len = int(std::min<Index>(kBlock, wcount - a0));
        for (int a = 0; a < len; ++a) e[a] = c.wnear[wact[wlo + a0 + a]];
        if (B::walls(c, e, len, block, scan, f.excess, f.fmax)) f.bad = 1;
      }
    } else {
      for (Index a = 0; a < wcount; ++a) {
        const Index e = c.wnear[wact[wlo + a]];
        const double lost = C::wall(c, e, f.excess);
        if (lost != 0) c.diss[c.wown[e]] += lost;
        if (c.wtouch[e]) mark(c.loaded, c.wown[e]);
        note_force(vec3(c.wforce, e), f);
      }
    }
  }

  // The whole pass, in one parallel region: each thread takes the near entries, then the
  // near-wall entries, that its particles own.
  // `cut`: the threads' parts of the particles (balance.hpp); each evaluates the entries its
  // particles own.
  static Found run(const ContactView& c, const Index* cut, Balance& parts, RegionTimes& times) {
    double excess = 0, fmax = 0;
    int bad = 0;
    RegionClock clock(times);
#pragma omp parallel num_threads(c.threads) reduction(max : excess, fmax, bad)
    {
      RegionClock::Stopwatch work;
      const Share me = share(c.n, cut, c.threads);
      Scan scan{};
      Block block(c.same);
      Found f;
      if (c.pairs > 0) pair_range(c, c.owned[me.lo], c.owned[me.hi], scan, block, f);
      wall_part(c, me.lo, me.hi, scan, block, f);
      excess = f.excess, fmax = f.fmax, bad = f.bad;
      work.stop();
      clock.done(work, me.t, me.nt, parts);
    }
    clock.close();
    return {excess, fmax, bad};
  }
};

}  // namespace tsubu::detail
