// Pass 2 of a step, over particles (2.2), a chunk of kChunk particles at a time: the particles of
// the chunk with an entry in contact sum their contacts (ContactSums, order fixed by ids) into
// v += dt F/m, w += dt T/I; then a dense pass over the chunk adds gravity and moves it,
// v += dt g, x += dt v (the chunk's velocities are still in the nearest cache), and bounds the
// distance moved for the neighbour lists by dt max|v|.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstring>

#include "views.hpp"

namespace tsubu::detail {

template <class Law>
struct ParticlePass {
  using F = Features<Law>;
  static constexpr Index kChunk = 2048, kStage = 4;

  // v += dt g, x += dt v over particles [lo, hi); returns max |v|^2 and a sum that is not
  // finite if a velocity is not; kRelative: also max |v - u|^2, u the Lees–Edwards mean flow at
  // the new position (the lists' bound, Domain::sheared_bound). Outside any OpenMP region, with
  // local accumulators and the maximum on the bits, so that gcc vectorises it.
  template <bool kRelative>
  [[gnu::noinline]] static void drift(double* x, double* v, Index lo, Index hi, double dt,
                                      const double gx, const double gy, const double gz,
                                      const Domain::MeanFlow& u, double& vmax2, double& rel2,
                                      double& check) {
    std::uint64_t top = 0, rtop = 0;
    double sum = 0;
    // (The flow's axis as a mask: no index into the velocity, which would stop the vectoriser.)
    const double ex = u.flow == 0 ? u.rate : 0.0, ey = u.flow == 1 ? u.rate : 0.0,
                 ez = u.flow == 2 ? u.rate : 0.0, centre = u.centre;
    const double on_x = u.gradient == 0 ? 1.0 : 0.0, on_y = u.gradient == 1 ? 1.0 : 0.0,
                 on_z = u.gradient == 2 ? 1.0 : 0.0;
    for (Index k = lo; k < hi; ++k) {
      const double vx = v[3 * k] + gx, vy = v[3 * k + 1] + gy, vz = v[3 * k + 2] + gz;
      v[3 * k] = vx;
      v[3 * k + 1] = vy;
      v[3 * k + 2] = vz;
      const double xx = x[3 * k] + dt * vx, xy = x[3 * k + 1] + dt * vy, xz = x[3 * k + 2] + dt * vz;
      x[3 * k] = xx;
      x[3 * k + 1] = xy;
      x[3 * k + 2] = xz;
      const double v2 = vx * vx + vy * vy + vz * vz;
      const std::uint64_t bits = order_bits(v2);
      top = top > bits ? top : bits;
      sum += nonfinite_flag(v2);
      if constexpr (kRelative) {  // (the gradient's coordinate picked by a mask, as the flow's)
        const double h = (on_x * xx + on_y * xy + on_z * xz) - centre;
        const double rx = vx - ex * h, ry = vy - ey * h, rz = vz - ez * h;
        const std::uint64_t r = order_bits(rx * rx + ry * ry + rz * rz);
        rtop = rtop > r ? rtop : r;
      }
    }
    vmax2 = from_order_bits(top);
    rel2 = from_order_bits(rtop);
    check = sum;
  }

  // The sums of a run of busy particles from the flat entry list (Simulation::sum_entry_):
  // entries [p0, p1) in one loop (flat_sums), each adding its force (and n x F_t moment) to its
  // particle's running sum, which restarts at zero at a particle's first entry; the sums go to
  // out[8 slot] (F in 0-2, T in 4-6), slot counting the particles from 0. The same additions in
  // the same order as ContactSums::at, so the same bits, without the three short loops per
  // particle whose exits the branch predictor misses.
  static constexpr bool kFlatSums = !F::kRolling && (F::kTangential || !F::kRough);
  static constexpr Index kFlatRun = 256;
  // Four doubles as one value (GCC's vector extension: an AVX register where there is one).
  typedef double V4 __attribute__((vector_size(32)));
  typedef std::int64_t M4 __attribute__((vector_size(32)));
  // a[0..2] and, in the fourth lane, whatever follows (the next entry, or the allocator's tail,
  // memory.hpp): one load instead of three; the fourth lane of the sums is never read.
  TSUBU_INLINE static V4 load4(const double* a) {
    V4 r;
    std::memcpy(&r, a, sizeof r);
    return r;
  }

  // The loop takes two runs of whole particles, entries [p0, pm) and [pm, p1), side by side:
  // each particle's sums are one chain of dependent additions, and two independent chains let
  // the core overlap them (the Lees–Edwards cell's particle pass: 3 % faster). The second
  // run's particles take slots from `slot_m` on.
  // kAsk: each run requests the force and moment of its entry kAskAhead places on, before the
  // loads that would wait for them (ParticleView::ask).
  static constexpr Index kAskAhead = 16;
  template <bool kAsk>
  [[gnu::noinline]] static void flat_sums(const std::uint32_t* __restrict entry, Index p0, Index pm,
                                          Index p1, std::int64_t slot_m, const ContactSums& sums,
                                          const double* rads, double* __restrict out) {
    // Indexed by the kind, so that the loop has no branch for gcc to guess: the arrays read,
    // the sign of the force (F - f is F + (-f), bit for bit).
    const double* force[4] = {sums.pf, sums.pf, sums.wf, sums.wf};
    const double* moment[4] = {sums.pn, sums.pn, sums.wn, sums.wn};
    const double* overlap[4] = {sums.po, sums.po, sums.wo, sums.wo};
    const double sign[4] = {1.0, -1.0, 1.0, 1.0};
    struct Run {
      std::int64_t slot;
      V4 F, T;
    };
    auto add = [&](Run& run, std::uint32_t u) {
      const std::uint32_t kind = u & 3u;
      const std::size_t e = u >> 3;
      const std::int64_t first = (u >> 2) & 1u;
      const M4 keep = M4{} + (first - 1);  // all ones but at a particle's first entry: from +0
      run.slot += first;
      run.F = V4(M4(run.F) & keep) + sign[kind] * load4(force[kind] + 3 * e);
      std::memcpy(out + 8 * run.slot, &run.F, sizeof run.F);
      if constexpr (Features<Law>::kTangential) {  // (1.19): both sides take -(r - overlap/2) n x F_t
        const double lever = contact_lever(rads[run.slot], overlap[kind][e]);
        run.T = V4(M4(run.T) & keep) - lever * load4(moment[kind] + 3 * e);
        std::memcpy(out + 8 * run.slot + 4, &run.T, sizeof run.T);
      }
    };
    Run a{-1, V4{0, 0, 0, 0}, V4{0, 0, 0, 0}}, b{slot_m - 1, V4{0, 0, 0, 0}, V4{0, 0, 0, 0}};
    const std::uint32_t *pa = entry + p0, *pb = entry + pm;
    auto ask = [&](std::uint32_t u) {
      const std::uint32_t kind = u & 3u;
      const std::size_t e = u >> 3;
      request(force[kind] + 3 * e);
      if constexpr (Features<Law>::kTangential) request(moment[kind] + 3 * e);
    };
    const Index both = std::min(pm - p0, p1 - pm);
    const Index asked = kAsk ? std::max<Index>(0, both - kAskAhead) : 0;
    for (Index k = 0; k < asked; ++k) {
      ask(pa[k + kAskAhead]);
      ask(pb[k + kAskAhead]);
      add(a, pa[k]);
      add(b, pb[k]);
    }
    for (Index k = asked; k < both; ++k) {
      add(a, pa[k]);
      add(b, pb[k]);
    }
    for (Index k = both; k < pm - p0; ++k) add(a, pa[k]);
    for (Index k = both; k < p1 - pm; ++k) add(b, pb[k]);
  }

  // Particles [c0, c1) (at most kChunk), whose busy ones start at busy[b] (b is moved past
  // them): kicks and drift. Raises vmax2 to max |v|^2 (and rel2 to max |v - u|^2 where
  // pv.relative); adds to `check` 0, or NaN if a new velocity is not finite.
  static void chunk(const ParticleView& pv, Index c0, Index c1, Index& b, double& vmax2,
                    double& rel2, double& check) {
    // Locals, and a lambda that captures them by value: the byte store to `loaded` may alias
    // anything in memory, and gcc would reload every member or captured reference after it.
    double *const v = pv.v, *const w = pv.w;
    const double *const inv_m = pv.inv_m, *const inv_i = pv.inv_i;
    std::uint8_t* const loaded = pv.loaded;
    const Index* const busy = pv.busy;
    const Index nb = pv.nb, body = pv.body_mask;
    const double dt = pv.dt;
    // Particle k in contact takes its sums: v += dt F/m, w += dt T/I. Returns 0, or NaN if
    // the new spin is not finite.
    auto kick = [=](Index k, const auto& F, const auto& T) {
      loaded[k] = 0;
      vec3(v, k) += (dt * inv_m[k & body]) * F;
      if constexpr (Features<Law>::kTorque) {
        const Vec3 wk = vec3(w, k) + (dt * inv_i[k & body]) * T;
        vec3(w, k) = wk;
        return nonfinite_flag(wk.sum());
      }
      return 0.0;
    };
    double kicked = 0;
    // The chunk's particles in contact, listed without branches; then their sums, each
    // requesting the data of the particles further down the list, in three stages
    // (ContactSums::prefetch: at N = 1e6 the particles in contact are a few per cent,
    // scattered, and each read would otherwise wait on memory).
    Index list[kChunk];
    Index count = 0;
    const Index b0 = b;
    for (; b < nb && busy[b] < c1; ++b) {
      const Index k = busy[b];
      list[count] = k;
      count += loaded[k] ? 1 : 0;
    }
    // Where most busy particles are in contact (dense packs), all of them are summed from
    // the flat entry list, and those in contact take their sums.
    if (kFlatSums && pv.flat && 2 * count >= b - b0) {
      for (Index r0 = b0; r0 < b; r0 += kFlatRun) {
        const Index r1 = std::min(b, r0 + kFlatRun);
        double rads[kFlatRun], out[8 * kFlatRun];
        for (Index a = r0; a < r1; ++a) rads[a - r0] = pv.radius[busy[a] & pv.radius_mask];
        const Index rm = r0 + (r1 - r0) / 2;
        const Index p0 = pv.sum_offset[r0], pm = pv.sum_offset[rm], p1 = pv.sum_offset[r1];
        if (pv.ask)
          flat_sums<true>(pv.sum_entry, p0, pm, p1, rm - r0, pv.sums, rads, out);
        else
          flat_sums<false>(pv.sum_entry, p0, pm, p1, rm - r0, pv.sums, rads, out);
        for (Index a = r0; a < r1; ++a) {
          const double* o = out + 8 * (a - r0);
          if (loaded[busy[a]])
            kicked += kick(busy[a], Eigen::Map<const Vec3>(o), Eigen::Map<const Vec3>(o + 4));
        }
      }
      count = 0;
    }
    const bool far = std::size_t(pv.n) >= ContactView::kFar;  // (else all in cache: no requests)
    for (Index a = 0; a < count; ++a) {
      if (far) {
        if (a + 3 * kStage < count) pv.sums.prefetch(list[a + 3 * kStage], v, w);
        if (a + 2 * kStage < count) pv.sums.prefetch_owned(list[a + 2 * kStage]);
        if (a + kStage < count) pv.sums.prefetch_reverse(list[a + kStage]);
      }
      const Index k = list[a];
      Vec3 F = Vec3::Zero(), T = Vec3::Zero();
      pv.sums.template at<Features<Law>::kTangential,
                          Features<Law>::kTangential || Features<Law>::kRough,
                          Features<Law>::kRolling>(k, F, T);
      kicked += kick(k, F, T);
    }
    double part_vmax2 = 0, part_rel2 = 0, part_check = 0;
    if (pv.relative)
      drift<true>(pv.x, v, c0, c1, dt, pv.gx, pv.gy, pv.gz, pv.flow, part_vmax2, part_rel2, part_check);
    else
      drift<false>(pv.x, v, c0, c1, dt, pv.gx, pv.gy, pv.gz, pv.flow, part_vmax2, part_rel2, part_check);
    vmax2 = std::max(vmax2, part_vmax2);
    rel2 = std::max(rel2, part_rel2);
    check += part_check + kicked;
  }

  // The whole pass. Returns true if a new velocity is not finite; sets vmax2 to max |v|^2 and,
  // where pv.relative, rel2 to max |v - u|^2.
  // `cut`: the threads' parts of the particles (balance.hpp).
  static bool run(const ParticleView& pv, const Index* cut, Balance& parts, double& vmax2_out,
                  double& rel2_out, RegionTimes& times) {
    double vmax2 = 0, rel2 = 0, check = 0;
    RegionClock clock(times);
#pragma omp parallel num_threads(pv.threads) reduction(max : vmax2, rel2) reduction(+ : check)
    {
      RegionClock::Stopwatch work;
      const Share me = share(pv.n, cut, pv.threads);
      Index b = pv.first_busy(me.lo);
      for (Index c0 = me.lo; c0 < me.hi; c0 += kChunk)
        chunk(pv, c0, std::min(me.hi, c0 + kChunk), b, vmax2, rel2, check);
      work.stop();
      clock.done(work, me.t, me.nt, parts);
    }
    clock.close();
    vmax2_out = vmax2;
    rel2_out = rel2;
    return !(check == 0);
  }
};

}  // namespace tsubu::detail
