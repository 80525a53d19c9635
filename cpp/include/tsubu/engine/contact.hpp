// One contact at a time: a near-pair or near-wall entry that touches, or touched at the last step,
// is measured (ContactGeometry), evaluated by the law and its results stored with it; an entry
// that has opened is cleared and its stored energy booked as dissipated. Laws with rolling
// friction or roughness take this path for all their contacts, the others for their walls only
// when blocked evaluation is off (block.hpp).
#pragma once
#include <algorithm>
#include <cmath>

#include "rough.hpp"
#include "views.hpp"

namespace tsubu::detail {

template <class Law>
struct Contacts {
  using F = Features<Law>;
  using History = typename Law::History;

  // A contact that opens loses the energy still stored in its tangential spring; q: the law's
  // packed tangential parameters.
  static void release(const double* q, double* xi, double& dissipated) {
    const double u2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
    if (u2 == 0) return;
    dissipated += Law::tangential::elastic_energy(q, xi);
    std::fill(xi, xi + Law::history_width, 0.0);
  }

  // Evaluates the law on geometry g with the entry's stored history; returns the result.
  TSUBU_INLINE static ContactResult evaluate(const ContactGeometry& g, const PairParams& p,
                                             double dt, double* xi) {
    History h;
    if constexpr (F::kHistory) std::copy(xi, xi + Law::history_width, h.xi);
    ContactResult res;
    Law::evaluate(g, p, dt, h, res);
    if constexpr (F::kHistory) std::copy(h.xi, h.xi + Law::history_width, xi);
    (void)xi;
    return res;
  }

  // v_ij.n (returned in vn) and the tangential velocity of the contact points (1.12), from the
  // relative velocity and the spins' part c_i w_i + c_j w_j, levers c along the line of centres.
  TSUBU_INLINE static L3 contact_velocity(L3 n, L3 vrel, L3 spin, double& vn) {
    vn = dot(vrel, n);
    if constexpr (F::kTangential) return vrel - vn * n - cross(spin, n);
    (void)spin;
    return {0, 0, 0};
  }
  TSUBU_INLINE static L3 spin_part(double ci, L3 wi, double cj, L3 wj) { return ci * wi + cj * wj; }
  TSUBU_INLINE static L3 approach(L3 n, L3 vrel, double ci, double cj, L3 wi, L3 wj, double& vn) {
    if constexpr (F::kTangential) return contact_velocity(n, vrel, spin_part(ci, wi, cj, wj), vn);
    (void)ci, (void)cj, (void)wi, (void)wj;
    return contact_velocity(n, vrel, {0, 0, 0}, vn);
  }

  // Where one kind of entry (near pairs, near walls) keeps its results.
  struct Results {
    std::uint8_t* touch;
    double *overlap, *force, *nxft, *roll, *xi;
  };
  static Results pair_results(const ContactView& c) {
    return {c.touch, c.overlap, c.force, c.nxft, c.roll, c.xi};
  }
  static Results wall_results(const ContactView& c) {
    return {c.wtouch, c.woverlap, c.wforce, c.wnxft, c.wroll, c.wxi};
  }
  // Pairs keep n x F where the law has friction or roughness; walls where it has friction.
  static constexpr bool kPairMoment = F::kTangential || F::kRough, kWallMoment = F::kTangential;

  // Ends a contact: its results go to zero and its tangential spring's energy is added to
  // `lost` (q: the law's packed tangential parameters).
  template <bool kMoment>
  TSUBU_INLINE static void end(const Results& r, Index e, const double* q, double& lost) {
    r.touch[e] = 0;
    r.overlap[e] = 0;
    vec3(r.force, e).setZero();
    if constexpr (F::kHistory) release(q, r.xi + Law::history_width * e, lost);
    if constexpr (kMoment) vec3(r.nxft, e).setZero();
    if constexpr (F::kRolling) vec3(r.roll, e).setZero();
    (void)q;
  }
  template <bool kMoment>
  static void end(const Results& r, Index e, const PairParams& p, double& lost) {
    double q[Law::tangential::kLaneParams > 0 ? Law::tangential::kLaneParams : 1];
    Law::tangential::pack(p, q);
    end<kMoment>(r, e, q, lost);
  }

  // What the normal spring of a sticky law's contact held at its last overlap, from the
  // parameters and the entry's terms: lost when it breaks (kSticky laws only).
  static double sticky_energy(const PairParams& p, const double* e, double overlap) {
    double q[Law::kLaneParams > 0 ? Law::kLaneParams : 1];
    Law::pack(p, q);
    return Law::lane_energy(q, e, overlap);
  }

  // Ends a pair contact; a rough pair also loses what its facet spring still holds, a sticky
  // one what its normal spring held.
  static double end_pair(const ContactView& c, Index q, const PairParams& params, const Vec3& d,
                         double rs, double dist2) {
    double lost = 0;
    if constexpr (Law::kSticky)
      lost += sticky_energy(params, c.entry + Law::kEntryTerms * (q & c.entry_mask), c.overlap[q]);
    end<kPairMoment>(pair_results(c), q, params, lost);
    if constexpr (F::kRough) {
      if (params.roughness > 0) {  // a facet spring still loaded is lost with it
        const double o = Rough<Law>::pair_overlap(c.rough + F::kRoughWidth * q, d, rs - std::sqrt(dist2));
        if (o > 0) lost += Law::normal_energy(params, o, c.r[c.own[q]] * c.r[c.par[q]] / rs);
      }
    }
    (void)d;
    (void)rs;
    (void)dist2;
    return lost;
  }

  // One near-pair entry that touches or has just stopped touching. Returns the energy it lost
  // this step; raises `excess` to its overlap beyond max_overlap x the smaller radius.
  TSUBU_INLINE static double pair(const ContactView& c, Index q, double inv_dist, double& excess) {
    const Index i = c.own[q], j = c.par[q];
    const double ri = c.r[i], rj = c.r[j], dt = c.dt;
    const Vec3 d = Domain::displacement(vec3(c.x, i), vec3(c.x, j));
    const double rs = ri + rj;
    const double dist2 = dot(lanes(d), lanes(d));
    const PairParams& params = (*c.table)(c.mat[i], c.mat[j]);
    const double* terms = c.entry + Law::kEntryTerms * (q & c.entry_mask);
    const double cut2 = c.cut2[q & c.cut_mask];
    if constexpr (Law::kSticky) {  // a touching contact holds to delta > -separation
      const double sep = Law::entry_separation(terms);
      if (c.touch[q] ? !(pair_overlap(ri, rj, dist2, inv_dist) > -sep) : dist2 >= cut2)
        return c.touch[q] ? end_pair(c, q, params, d, rs, dist2) : 0.0;
    } else {
      if (dist2 >= cut2) return end_pair(c, q, params, d, rs, dist2);  // (1.10)
    }
    ContactGeometry g;
    const double overlap = pair_overlap(ri, rj, dist2, inv_dist);
    g.delta = overlap;
    const Vec3 n = d * inv_dist;
    g.n = n;
    excess = std::max(excess, g.delta - c.limit * std::min(ri, rj));
    std::copy(terms, terms + Law::kEntryTerms, g.entry);
    if constexpr (F::kRough) g.m_eff = c.m[i] * c.m[j] / (c.m[i] + c.m[j]);
    const Vec3 vrel = vec3(c.v, i) - vec3(c.v, j);
    if constexpr (F::kTorque) {
      g.ci = contact_lever(ri, g.delta);
      g.cj = contact_lever(rj, g.delta);
    }
    bool tilted = false;
    if constexpr (F::kRough) {
      if (params.roughness > 0) {
        const ContactStream stream{c.seed, std::uint64_t(c.ids[i]), std::uint64_t(c.ids[j]),
                                   c.step};
        double virtual_overlap = 0;
        const Vec3 spin = (g.ci * vec3(c.w, i) + g.cj * vec3(c.w, j)).cross(n);
        g.n = Rough<Law>::pair(params, n, d, g.delta, vrel, spin,
                               ContactScale{g.m_eff, ri * rj / rs, c.speed}, c.touch[q],
                               c.rough + F::kRoughWidth * q, stream, dt, virtual_overlap);
        if (!(virtual_overlap > 0))  // not (or no longer) pressed across the facet
          return c.touch[q] ? end_pair(c, q, params, d, rs, dist2) : 0.0;
        g.delta = virtual_overlap;
        tilted = true;
      }
    }
    if (!tilted) {
      const L3 vt = approach(lanes(n), lanes(vrel), g.ci, g.cj, lanes(vec3(c.w, i)),
                             lanes(vec3(c.w, j)), g.vn);
      if constexpr (F::kTangential) g.vt = vec(vt);
    } else {
      // Contact points on the line of centres; normal and tangential parts relative to n'.
      const Vec3 spin = (g.ci * vec3(c.w, i) + g.cj * vec3(c.w, j)).cross(n);
      const Vec3 vcp = vrel - spin;
      g.vn = vcp.dot(g.n);
      if constexpr (F::kTangential) g.vt = vcp - g.vn * g.n;
    }
    if constexpr (F::kRolling) {
      g.w_rel = vec3(c.w, i) - vec3(c.w, j);
      g.ri = ri;
      g.rj = rj;
      g.spin_mobility = ri * c.inv_i[i] + rj * c.inv_i[j];
    }
    if constexpr (F::kTangential)  // (tilted: the stored moment is the whole force's, n x F)
      g.prev_n_cross_ft = tilted ? Vec3(g.n.cross(vec3(c.force, q))) : Vec3(vec3(c.nxft, q));
    ContactResult res = evaluate(g, params, dt, c.xi + Law::history_width * q);
    c.touch[q] = 1;
    c.overlap[q] = overlap;  // geometric: it sets the levers c = r - overlap/2
    vec3(c.force, q) = res.force;
    // (1.19) with the contact-point lever c_i along the line of centres; with a tilted normal
    // the whole force has a moment about the centres (n x F), which keeps angular momentum exact.
    if constexpr (F::kTangential || F::kRough)
      vec3(c.nxft, q) = tilted ? Vec3(n.cross(res.force)) : res.n_cross_ft;
    if constexpr (F::kRolling) {  // (the torque averaged over the steps around the turn, as F_t)
      res.power -= 0.5 * (res.roll + vec3(c.roll, q)).dot(ri * vec3(c.w, i) - rj * vec3(c.w, j));
      vec3(c.roll, q) = res.roll;
    }
    return res.power * dt;
  }

  // A wall contact's approach along n at the contact point x_i - c n (lever c = r - delta/2,
  // set in `ci`): returns v_n; sets the tangential velocity (1.12) where the law has one.
  TSUBU_INLINE static double wall_approach(const ContactView& c, const Wall& P, Index i, const Vec3& n,
                              double delta, double& ci, Vec3& vt) {
    ci = contact_lever(c.r[i & c.cut_mask], delta);
    Vec3 vrel = vec3(c.v, i);
    if (c.moving) vrel -= P.velocity_at(Wall::contact_point(vec3(c.x, i), ci, n));
    const double vn = vrel.dot(n);
    if constexpr (F::kTangential) vt = vrel - vn * n - (ci * vec3(c.w, i)).cross(n);
    return vn;
  }

  // One near-wall entry that touches, or touched last step. Returns the energy it lost; raises
  // `excess` as pair().
  static double wall(const ContactView& c, Index e, double& excess) {
    const Index i = c.wown[e];
    const Wall& P = wall_plane(c, e);
    const PairParams& params = (*c.table)(c.mat[i], P.material);
    const Vec3 xi_pos = vec3(c.x, i);
    const double ri = c.r[i], dt = c.dt;
    double delta = P.overlap(xi_pos, ri);  // (3.1), signed: a half-space
    Vec3 n = P.normal_at(xi_pos);
    if constexpr (F::kRough) {
      if (params.roughness > 0) {
        Vec3 vw = vec3(c.v, i);
        if (c.moving) vw -= P.velocity_at(Wall::contact_point(xi_pos, ri, n));
        // (a mesh's triangle in the high bits: a plane's element is 0)
        const ContactStream stream{c.seed, std::uint64_t(c.ids[i]),
                                   ContactStream::kWallTag + std::uint64_t(c.wall[e]) + (std::uint64_t(c.welement[e]) << 32),
                                   c.step};
        Rough<Law>::wall(params, P, xi_pos, ri, vw, ContactScale{c.m[i], ri, c.speed}, c.wtouch[e],
                         c.wrough + F::kRoughWidth * e, stream, dt, n, delta);
      }
    }
    ContactGeometry g;
    if constexpr (Law::kSticky) {  // a touching contact holds to delta > -separation
      Law::entry_terms(params, c.m[i], ri, g.entry);  // (a wall: R* = r_i, m* = m_i)
      if (!(delta > (c.wtouch[e] ? -Law::entry_separation(g.entry) : 0.0))) {
        double lost = 0;
        if (c.wtouch[e]) {
          lost += sticky_energy(params, g.entry, c.woverlap[e]);
          end<kWallMoment>(wall_results(c), e, params, lost);
        }
        return lost;
      }
    } else {
      if (delta <= 0) {
        double lost = 0;
        if (c.wtouch[e]) end<kWallMoment>(wall_results(c), e, params, lost);
        return lost;
      }
    }
    g.n = n;
    g.delta = delta;
    excess = std::max(excess, delta - c.limit * ri);
    g.m_eff = c.m[i];
    if constexpr (!Law::kSticky) Law::entry_terms(params, g.m_eff, ri, g.entry);  // (a wall: R* = r_i)
    g.cj = 0;
    g.vn = wall_approach(c, P, i, n, delta, g.ci, g.vt);
    if constexpr (F::kRolling) {
      g.w_rel = vec3(c.w, i);
      if (c.moving) g.w_rel -= P.angular_velocity;
      g.ri = ri;
      g.rj = 0;
      g.spin_mobility = ri * c.inv_i[i];
    }
    if constexpr (F::kTangential) g.prev_n_cross_ft = vec3(c.wnxft, e);
    ContactResult res = evaluate(g, params, dt, c.wxi + Law::history_width * e);
    c.wtouch[e] = 1;
    c.woverlap[e] = delta;
    vec3(c.wforce, e) = res.force;
    // The lever runs along the (facet) normal: the wall's surface.
    if constexpr (F::kTangential) vec3(c.wnxft, e) = res.n_cross_ft;
    if constexpr (F::kRolling) {
      res.power -= 0.5 * ri * (res.roll + vec3(c.wroll, e)).dot(g.w_rel);
      vec3(c.wroll, e) = res.roll;
    }
    return res.power * dt;
  }
};

}  // namespace tsubu::detail
