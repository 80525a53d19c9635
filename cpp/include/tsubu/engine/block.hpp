// Blocked evaluation, for laws without rolling friction or roughness: a gather loop reads each
// kept contact's geometry, velocities, parameters and history into a structure of arrays; one
// loop runs the law's lane form over the block, which the compiler vectorises (AVX2: 4 contacts
// at a time); a store loop writes the results back. The arithmetic is that of contact.hpp's
// single contacts, in the same order, so are the bits.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "contact.hpp"

namespace tsubu::detail {

constexpr int kBlock = 64;

// The pair entries of a chunk that are in contact or were last step, as the scan keeps them:
// entry, x_i - x_j, its squared length and 1/|x_ij|.
struct Scan {
  Index act[kBlock];
  double dx[kBlock], dy[kBlock], dz[kBlock], d2[kBlock], inv[kBlock];
};

template <class Law>
struct Blocked {
  using F = Features<Law>;
  using C = Contacts<Law>;
  static constexpr int kParams = Law::kLaneParams;
  static constexpr int kHistory = Law::history_width;
  static constexpr int kEntry = Law::kEntryTerms;

  struct alignas(64) Block {
    // Walls: normal, tangential and normal velocity. Pairs: relative velocity and the spins'
    // part (the rest of the geometry is the scan's), turned into n, v_t and v_n by the
    // vectorised loop.
    double nx[kBlock], ny[kBlock], nz[kBlock], vtx[kBlock], vty[kBlock], vtz[kBlock], vn[kBlock];
    double vrx[kBlock], vry[kBlock], vrz[kBlock], spx[kBlock], spy[kBlock], spz[kBlock];
    double delta[kBlock];
    double entry[kEntry][kBlock];   // the entry's terms (ContactLaw::entry_terms), one column each
    double param[kParams][kBlock];  // the law's packed pair parameters, one column each
    double xix[kBlock], xiy[kBlock], xiz[kBlock];
    double xia[kHistory > 3 ? kBlock : 1];  // a history's fourth value, where it has one
    double fx[kBlock], fy[kBlock], fz[kBlock], tx[kBlock], ty[kBlock], tz[kBlock], power[kBlock];
    bool inside[kBlock];
    std::int32_t far[Law::kDeferred ? kBlock : 1];  // lanes the law must evaluate again (evaluate)

    // One material for all spheres: the parameter lanes are filled once, not per contact.
    explicit Block(const PairParams* same) {
      // Zeros, so that the lanes past a block's end (evaluate) hold finite values.
      std::memset(static_cast<void*>(this), 0, sizeof *this);
      if (!same) return;
      double q[kParams];
      Law::pack(*same, q);
      for (int k = 0; k < kParams; ++k) std::fill(param[k], param[k] + kBlock, q[k]);
    }
    // Lane a's tangential parameters, as the law packed them.
    std::array<double, Law::tangential::kLaneParams + 1> param_column_tangential(int a) const {
      std::array<double, Law::tangential::kLaneParams + 1> q{};
      for (int k = 0; k < Law::tangential::kLaneParams; ++k) q[k] = param[Law::kNormalParams + k][a];
      return q;
    }
    void put_params(int a, const PairParams& p) {
      double q[kParams];
      Law::pack(p, q);
      for (int k = 0; k < kParams; ++k) param[k][a] = q[k];
    }
  };

  // Entries s.act[0, len), len <= kBlock, as Contacts::pair for each, in order. Returns true if
  // a force is not finite.
  TSUBU_INLINE static bool pairs(const ContactView& c, const Scan& s, int len, Block& b,
                                 double& excess, double& fmax) {
    // (The block's own loops for one material, and for entries that share one cut and one set
    // of terms (NeighborList::cut_mask): values read once, not per lane.)
    const bool one = c.cut_mask == 0 && c.entry_mask == 0;
    if (c.same && one)
      gather<true, true>(c, s, len, b, excess);
    else if (c.same)
      gather<true, false>(c, s, len, b, excess);
    else
      gather<false, false>(c, s, len, b, excess);
    const bool bad = evaluate<true>(b, s, len, c.dt, fmax);
    store(c, s.act, len, b);
    return bad;
  }

  // Requests what the gather and store of entries s.act[0, len) read from memory: the
  // partners' (and owners') velocities and spins, the entries' histories and the owners'
  // dissipation sums. Where the contacts are few and scattered (a large scene), each is a miss;
  // requested together, the misses overlap instead of queueing behind the gather's long
  // iterations. (Also where the near pairs are many, ContactView::ask: their state is then in
  // the last-level cache, not a nearer one.)
  static void request_pairs(const ContactView& c, const Scan& s, Index len) {
    for (Index a = 0; a < len; ++a) {
      const Index q = s.act[a], i = c.own[q], j = c.par[q];
      request(c.v + 3 * j);
      request(c.v + 3 * i);
      if constexpr (F::kTangential) {
        request(c.w + 3 * j);
        request(c.w + 3 * i);
        request(c.nxft + 3 * q);
      }
      if constexpr (F::kHistory) request(c.xi + kHistory * q);
      request(c.diss + i);
    }
  }

  template <bool kSame, bool kOne>
  static void gather(const ContactView& c, const Scan& s, int len, Block& b, double& excess) {
    // The view's pointers as locals, and the largest excess in a local: the byte store to
    // b.inside may alias anything, and gcc would reload each of them after it.
    const Index *const own = c.own, *const par = c.par;
    const double *const r = c.r, *const v = c.v, *const w = c.w, *const cut2 = c.cut2;
    const double *const entry = c.entry, *const history = c.xi, *const moment = c.nxft;
    const std::uint8_t* const touch = c.touch;
    const Index cut_mask = kOne ? 0 : c.cut_mask, entry_mask = kOne ? 0 : c.entry_mask;
    const double limit = c.limit, r0 = r[0];
    double most = excess;
    for (int a = 0; a < len; ++a) {
      const Index q = s.act[a], i = own[q], j = par[q];
      const double ri = kOne ? r0 : r[i], rj = kOne ? r0 : r[j];  // (alike spheres: one radius)
      const double dist2 = s.d2[a], inv = s.inv[a];
      const double delta = pair_overlap(ri, rj, dist2, inv);
      const double ci = contact_lever(ri, delta), cj = contact_lever(rj, delta);
      const L3 vrel = lanes(vec3(v, i) - vec3(v, j));
      b.vrx[a] = vrel.x, b.vry[a] = vrel.y, b.vrz[a] = vrel.z;
      if constexpr (F::kTangential) {
        const L3 spin = C::spin_part(ci, lanes(vec3(w, i)), cj, lanes(vec3(w, j)));
        b.spx[a] = spin.x, b.spy[a] = spin.y, b.spz[a] = spin.z;
      }
      const double* terms = entry + kEntry * (q & entry_mask);
      bool inside = dist2 < cut2[q & cut_mask];  // (1.10); else the contact has just opened
      if constexpr (Law::kSticky)  // a touching contact holds to delta > -separation
        if (touch[q]) inside = delta > -Law::entry_separation(terms);
      b.inside[a] = inside;
      if (inside) most = std::max(most, delta - limit * std::min(ri, rj));
      b.delta[a] = delta;
      for (int k = 0; k < kEntry; ++k) b.entry[k][a] = terms[k];
      if constexpr (!kSame) b.put_params(a, (*c.table)(c.mat[i], c.mat[j]));
      if constexpr (F::kHistory) {
        const double* xi = history + kHistory * q;
        b.xix[a] = xi[0], b.xiy[a] = xi[1], b.xiz[a] = xi[2];
        if constexpr (kHistory > 3) b.xia[a] = xi[3];
      }
      if constexpr (F::kTangential) {
        const double* t = moment + 3 * q;
        b.tx[a] = t[0], b.ty[a] = t[1], b.tz[a] = t[2];
      }
    }
    excess = most;
  }

  // Lane a of the block through the law, its results in place of its inputs; returns F.
  // kSeriesOnly (laws with Law::kDeferred): `far` set where the law skipped a rare step, that
  // lane's inputs kept and its results to be thrown away (evaluate runs it again, in full).
  template <bool kPairs, bool kSeriesOnly>
  TSUBU_INLINE static L3 lane_at(Block& __restrict b, const Scan& __restrict s, int a, double dt,
                                 bool& far) {
    L3 n, vt;
    double vn;
    if constexpr (kPairs) {
      n = s.inv[a] * L3{s.dx[a], s.dy[a], s.dz[a]};
      const L3 spin = F::kTangential ? L3{b.spx[a], b.spy[a], b.spz[a]} : L3{0, 0, 0};
      vt = C::contact_velocity(n, {b.vrx[a], b.vry[a], b.vrz[a]}, spin, vn);
    } else {
      n = {b.nx[a], b.ny[a], b.nz[a]};
      vt = {b.vtx[a], b.vty[a], b.vtz[a]};
      vn = b.vn[a];
    }
    double q[kParams], e[kEntry];
    for (int k = 0; k < kParams; ++k) q[k] = b.param[k][a];
    for (int k = 0; k < kEntry; ++k) e[k] = b.entry[k][a];
    // (t: last step's n x F_t in, this step's out; the tangential law's energy booking reads it)
    const L3 xi0{b.xix[a], b.xiy[a], b.xiz[a]}, t0{b.tx[a], b.ty[a], b.tz[a]};
    const double aux0 = kHistory > 3 ? b.xia[kHistory > 3 ? a : 0] : 0.0;
    L3 xi = xi0, f, t = t0;
    double aux = aux0, power;
    Law::template lane_as<kSeriesOnly>(n, vt, b.delta[a], vn, e, q, dt, xi, aux, f, t, power, far);
    if constexpr (kSeriesOnly) {
      xi = select(far, xi0, xi);
      t = select(far, t0, t);
      aux = far ? aux0 : aux;
    }
    b.xix[a] = xi.x, b.xiy[a] = xi.y, b.xiz[a] = xi.z;
    if constexpr (kHistory > 3) b.xia[a] = aux;
    b.fx[a] = f.x, b.fy[a] = f.y, b.fz[a] = f.z;
    b.tx[a] = t.x, b.ty[a] = t.y, b.tz[a] = t.z;
    b.power[a] = power;
    return f;
  }

  // The law over lanes [0, len) of a block of pairs (kPairs: the normal from the scan's x_ij and
  // 1/|x_ij|, the velocities from the block's) or of walls (s unused). Returns true if a
  // contact's force is not finite.
  template <bool kPairs>
  [[gnu::noinline]] static bool evaluate(Block& __restrict b, const Scan& __restrict s, int len,
                                         double dt, double& fmax) {
    // With a 32-bit `bad`, gcc runs 8 lanes per vector iteration (two independent chains of
    // divisions and square roots, which the core overlaps) and the rest one at a time, each a
    // long serial chain: the block is run to the next multiple of 8 instead. The extra lanes
    // hold an earlier block's values (or zeros): their results are not read, not counted bad.
    static_assert(kBlock % 8 == 0);
    constexpr bool kDeferred = Law::kDeferred;
    const int padded = (len + 7) & ~7;
    int bad = 0, again = 0;
    std::uint64_t top = order_bits(fmax);  // the largest |fx| + |fy| + |fz| (>= |F|)
    auto note = [&](const L3& f, int a, bool skip) {
      const double sum = (f.x + f.y) + f.z;
      bad |= (is_finite(sum) || a >= len || skip) ? 0 : 1;  // (a just-opened lane's stay finite)
      const std::uint64_t size = order_bits((std::abs(f.x) + std::abs(f.y)) + std::abs(f.z));
      top = top > size ? top : size;  // (the padding lanes' earlier forces too: a bound)
    };
    for (int a = 0; a < padded; ++a) {
      bool far = false;
      const L3 f = lane_at<kPairs, kDeferred>(b, s, a, dt, far);
      if constexpr (kDeferred) b.far[a] = far ? 1 : 0;
      note(f, a, far);  // (a far lane's force, redone below, only raises the bound)
    }
    if constexpr (kDeferred) {
      // (Counted in a loop of its own: in the loop above, gcc would not vectorise.)
      for (int a = 0; a < len; ++a) again |= b.far[a];
      if (again)  // rare: a contact whose normal turned by more than ~1/300 rad in one step
        for (int a = 0; a < len; ++a)
          if (b.far[a]) {
            bool unused = false;
            note(lane_at<kPairs, false>(b, s, a, dt, unused), a, false);
          }
    }
    fmax = from_order_bits(top);
    return bad != 0;
  }

  using Results = typename C::Results;

  // Lane a of a block back to entry q: its results, or, where the contact has just opened,
  // zeros and the energy its tangential spring held. Returns the energy lost this step.
  TSUBU_INLINE static double store_lane(const Results& r, Index q, const Block& b, int a,
                                        double dt) {
    double lost = 0;
    if (b.inside[a]) {
      r.touch[q] = 1;
      r.overlap[q] = b.delta[a];
      double* f = r.force + 3 * q;
      f[0] = b.fx[a], f[1] = b.fy[a], f[2] = b.fz[a];
      if constexpr (F::kTangential) {
        double* t = r.nxft + 3 * q;
        t[0] = b.tx[a], t[1] = b.ty[a], t[2] = b.tz[a];
        double* xi = r.xi + kHistory * q;
        xi[0] = b.xix[a], xi[1] = b.xiy[a], xi[2] = b.xiz[a];
        if constexpr (kHistory > 3) xi[3] = b.xia[a];
      }
      lost = b.power[a] * dt;
    } else {
      end_lane(r, q, b, a, lost);
    }
    return lost;
  }

  // A lane whose contact has just opened (rare: out of line, to keep the store loop's registers).
  // (r by value: a reference would make the caller keep its pointers in memory, reloaded after
  // every byte store.)
  [[gnu::noinline]] static void end_lane(Results r, Index q, const Block& b, int a, double& lost) {
    if constexpr (Law::kSticky) {  // the normal spring's energy at its last overlap is lost
      double p[kParams], e[kEntry];
      for (int k = 0; k < kParams; ++k) p[k] = b.param[k][a];
      for (int k = 0; k < kEntry; ++k) e[k] = b.entry[k][a];
      lost += Law::lane_energy(p, e, r.overlap[q]);
    }
    C::template end<F::kTangential>(r, q, b.param_column_tangential(a).data(), lost);  // (no roughness here)
  }

  static void store(const ContactView& c, const Index* act, int len, const Block& b) {
    // The pointers as locals: the byte stores (touch, loaded) may alias anything in memory,
    // and gcc would reload each pointer from `c` after every one of them.
    const Results pairs = C::pair_results(c);
    const Index *own = c.own, *par = c.par;
    std::uint8_t* loaded = c.loaded;
    double* diss = c.diss;
    const double dt = c.dt;
    for (int a = 0; a < len; ++a) {
      const Index q = act[a], i = own[q];
      const double lost = store_lane(pairs, q, b, a, dt);
      if (b.inside[a]) {
        mark(loaded, i);
        mark(loaded, par[q]);
      }
      diss[i] += lost;  // (+0 where nothing was lost)
    }
  }

  // Near-wall entries e[0, len) in contact or just released, as Contacts::wall for each, in
  // order, through the same block as pairs: the law's lanes take a wall as a partner with no
  // radius, no spin and the plane's material. Returns true if a force is not finite.
  static bool walls(const ContactView& c, const Index* e, int len, Block& b, const Scan& scan,
                    double& excess, double& fmax) {
    for (int a = 0; a < len; ++a) {
      const Index i = c.wown[e[a]];
      const Wall& P = wall_plane(c, e[a]);
      const PairParams& p = (*c.table)(c.mat[i & c.entry_mask], P.material);
      const Vec3 xi_pos = vec3(c.x, i);
      const double ri = c.r[i & c.cut_mask];
      const double delta = P.overlap(xi_pos, ri);  // (3.1), signed: a half-space
      const Vec3& n = P.normal_at(xi_pos);
      double terms[kEntry];
      if constexpr (Law::kSticky) {  // a touching contact holds to delta > -separation
        Law::entry_terms(p, c.m[i & c.entry_mask], ri, terms);  // (a wall: R* = r_i, m* = m_i)
        b.inside[a] = delta > (c.wtouch[e[a]] ? -Law::entry_separation(terms) : 0.0);
      } else {
        b.inside[a] = delta > 0;
      }
      if (b.inside[a]) excess = std::max(excess, delta - c.limit * ri);
      double ci;
      Vec3 vt = Vec3::Zero();
      const double vn = C::wall_approach(c, P, i, n, delta, ci, vt);
      b.nx[a] = n.x(), b.ny[a] = n.y(), b.nz[a] = n.z();
      b.vtx[a] = vt.x(), b.vty[a] = vt.y(), b.vtz[a] = vt.z();
      b.delta[a] = delta, b.vn[a] = vn;
      if constexpr (!Law::kSticky) Law::entry_terms(p, c.m[i & c.entry_mask], ri, terms);  // (a wall: R* = r_i, m* = m_i)
      for (int k = 0; k < kEntry; ++k) b.entry[k][a] = terms[k];
      b.put_params(a, p);
      if constexpr (F::kHistory) {
        const double* xi = c.wxi + kHistory * e[a];
        b.xix[a] = xi[0], b.xiy[a] = xi[1], b.xiz[a] = xi[2];
        if constexpr (kHistory > 3) b.xia[a] = xi[3];
      }
      if constexpr (F::kTangential) {
        const double* t = c.wnxft + 3 * e[a];
        b.tx[a] = t[0], b.ty[a] = t[1], b.tz[a] = t[2];
      }
    }
    const bool bad = evaluate<false>(b, scan, len, c.dt, fmax);  // (the scan is not read)
    const Results walls = C::wall_results(c);
    for (int a = 0; a < len; ++a) {
      const Index i = c.wown[e[a]];
      const double lost = store_lane(walls, e[a], b, a, c.dt);
      if (b.inside[a]) mark(c.loaded, i);
      if (lost != 0) c.diss[i] += lost;
    }
    return bad;
  }
};

}  // namespace tsubu::detail
