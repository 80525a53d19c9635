// The time loop, written once as a template over the contact law and the wall motion. Each
// specialisation is instantiated in registry.cpp; a run picks one when it starts.
//
// One step (symplectic Euler, 2.2) is two passes. The contact pass runs over the near list
// (pairs within r_i + r_j + skin/10) and the near-wall list as flat arrays: a branch-free scan
// compacts the entries in contact (or just released) into a list, and only those are evaluated;
// each entry's result is stored with it. The particle pass then sums every particle's entries in
// an order fixed by ids (ContactSums) and advances v^{n+1} = v^n + dt F/m, w^{n+1} = w^n + dt T/I,
// x^{n+1} = x^n + dt v^{n+1}. No per-particle force arrays are streamed, and results are
// bit-identical for any thread count and any rebuild schedule. In large scenes, whose arrays do
// not stay in cache from one pass to the next, a step's particle pass and the next step's
// contact pass are one sweep (fused_pass) whenever no neighbour list can fall due in between.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "contact/law.hpp"
#include "contact/roughness.hpp"
#include "simulation.hpp"

namespace tsubu::detail {

template <class Law, bool MovingWalls>
struct Stepper {
  using History = typename Law::History;
  static constexpr bool kHistory = Law::has_history;
  static constexpr bool kTorque = Law::has_torque;
  static constexpr bool kTangential = Law::tangential::enabled;
  static constexpr bool kRolling = Law::rolling::enabled;
  static constexpr bool kRough = Law::roughness::enabled;
  // Roughness state per entry: walls: tilt vector (3), facet offset h, first-touch step;
  // pairs: tilted normal n' (3; zero once enduring), facet offset H, first-touch step, spin term S.
  static constexpr std::size_t kRoughWidth = 6;

  static void run(Simulation& s, long steps) {
    const double dt = s.dt_;
    PhaseTimer clock(s.phase_seconds_);
    // With fixed walls no energy enters the scene: the balance is checked every kEnergyCheck
    // steps (Simulation::check_energy), which catches the bounded bursts that a dense pack run
    // above its own (lower) bound goes through without any overlap limit.
    if (MovingWalls) {
      s.energy_ref_valid_ = false;
    } else if (!s.energy_ref_valid_ || s.energy_ref_gravity_ != s.opt_.gravity) {
      s.energy_ref_ = s.energy_now();
      s.energy_ref_valid_ = true;
      s.energy_ref_gravity_ = s.opt_.gravity;
      s.energy_ref_step_ = s.step_;
    }
    // Large scenes with fixed walls fuse a step's particle pass with the next step's contact
    // pass (fused_pass) whenever no neighbour list can be due in between; the first and the
    // last step of a run, and those that end on an energy check, run as two passes.
    const bool fuse = fuses(s) && steps > 2;
    const double min_mass =
        fuse ? *std::min_element(s.mass_.data(), s.mass_.data() + s.n_) : 0.0;
    double vmax2 = -1;  // max |v|^2 after the last step; < 0: not known yet
    bool ready = false;  // this step's contacts were evaluated by the last step's fused pass
    Found found;
    for (long k = 0; k < steps; ++k) {
      if (!ready) {
        if (s.needs_rebuild()) {
          s.rebuild(true);
        } else if (s.needs_refresh()) {
          s.stash_near();
          s.refresh_near(true, false);
        }
        clock.lap(Phase::Neighbors);
        found = contact_pass(s, dt);
        clock.lap(Phase::Contacts);
      } else if (s.needs_rebuild() || s.needs_refresh()) {
        throw std::logic_error("tsubu: a fused step moved particles further than its bound");
      }
      if (found.excess > 0) s.report_overlap(dt);
      if (found.bad) s.report_nonfinite();
      ready = fuse && k > 0 && k + 1 < steps && (s.step_ + 1) % Simulation::kEnergyCheck != 0 &&
              fusable(s, dt, vmax2, found, min_mass);
      s.fused_steps_ += ready ? 1 : 0;
      const bool nonfinite =
          ready ? fused_pass(s, dt, vmax2, found) : particle_pass(s, dt, vmax2);
      if (nonfinite) s.report_nonfinite_velocity();
      if constexpr (MovingWalls) s.move_planes(dt);
      ++s.step_;
      s.time_ += dt;
      if (!MovingWalls && s.step_ % Simulation::kEnergyCheck == 0) s.check_energy(s.energy_ref_);
      clock.lap(Phase::Integrate);
    }
  }

  // A contact that opens loses the energy still stored in its tangential spring.
  static void release(double kt, double* xi, double& dissipated) {
    const double u2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
    if (u2 == 0) return;
    dissipated += 0.5 * kt * u2;
    std::fill(xi, xi + 3, 0.0);
  }

  // Evaluates the law on geometry g with the entry's stored history; returns the result.
  TSUBU_INLINE static ContactResult evaluate(const ContactGeometry& g, const PairParams& p, double dt,
                                double* xi) {
    History h;
    if constexpr (kHistory) std::copy(xi, xi + 3, h.xi);
    ContactResult res;
    Law::evaluate(g, p, dt, h, res);
    if constexpr (kHistory) std::copy(h.xi, h.xi + 3, xi);
    (void)xi;
    return res;
  }

  // A rough contact older than two contact durations is an enduring contact, not an impact: its
  // tilt is dropped (docs/roughness.md), so spheres at rest do not roll down virtual facets.
  static bool enduring(const PairParams& p, double m, const double* st, std::uint64_t step,
                       double dt) {
    if (st[0] == 0 && st[1] == 0 && st[2] == 0) return false;
    const double eta = HookeNormal::damping(p, m);
    const double alpha = std::sqrt(p.kn / m - eta * eta / (4 * m * m));  // (B.3)
    return (double(step) - st[4]) * dt > 2.0 * M_PI / alpha;
  }

  // Rough pair (docs/roughness.md): at first touch a tilted normal n' is drawn and frozen for
  // the impact, and the spheres meet a virtual facet across it: the overlap is measured along
  // n', delta' = H - n'.x_ij + S, where S integrates the spin part of the contact points'
  // approach, so that d(delta')/dt = -n'.v_cp and the normal spring keeps its energy. An
  // enduring contact (older than 2 t_c) turns back to the line of centres with the overlap
  // kept: delta' = delta + H. Returns n' (n once enduring) and sets delta' (<= 0: no contact).
  static Vec3 rough_pair(const PairParams& p, const Vec3& n, const Vec3& xij, double delta,
                         const Vec3& vrel, const Vec3& spin, double m, bool active, double* st,
                         const ContactStream& stream, double dt, double& overlap) {
    if (!active) {
      const Vec3 tilt = draw_tilt(p, n, vrel, false, stream);
      const Vec3 np = std::sqrt(1.0 - tilt.squaredNorm()) * n + tilt;
      std::copy(np.data(), np.data() + 3, st);
      st[3] = std::min(delta, -vrel.dot(np) * dt) + np.dot(xij);  // H: starts at <= one step
      st[4] = double(stream.step);
      st[5] = 0.0;
    } else if (!(st[0] == 0 && st[1] == 0 && st[2] == 0) && enduring(p, m, st, stream.step, dt)) {
      const double current = st[3] - Eigen::Map<const Vec3>(st).dot(xij) + st[5];
      std::fill(st, st + 3, 0.0);
      st[3] = current - delta;
    }
    if (st[0] == 0 && st[1] == 0 && st[2] == 0) {  // enduring: back on the line of centres
      overlap = delta + st[3];
      return n;
    }
    const Vec3 np = Eigen::Map<const Vec3>(st);
    // The spin part of the last step's approach, with the spins that moved the spheres (as the
    // positions were moved with the new velocities: symplectic, not explicit, Euler).
    if (active) st[5] += np.dot(spin) * dt;
    overlap = st[3] - np.dot(xij) + st[5];
    return np;
  }

  // The virtual overlap of a rough pair entry (for the energy lost when it opens).
  static double rough_pair_overlap(const double* st, const Vec3& xij, double delta) {
    if (st[0] == 0 && st[1] == 0 && st[2] == 0) return delta + st[3];
    return st[3] - Eigen::Map<const Vec3>(st).dot(xij) + st[5];
  }

  // Rough wall: the sphere meets a virtual plane (a facet) tilted by dG, fixed to the wall at
  // offset h (n'.(y - p) = h), placed at first touch so that the sphere penetrates it by at
  // most one step of approach. On entry n is the wall normal and delta the real overlap; on
  // exit they are the facet's normal and overlap (<= 0: no contact).
  static void rough_wall(const PairParams& p, const Plane& P, const Vec3& x, double r,
                         const Vec3& vrel, double m, bool active, double* st,
                         const ContactStream& stream, double dt, Vec3& n, double& delta) {
    if (!active) {
      // A facet contact starts when the sphere touches the real wall while approaching it.
      // (st[5] is unused for walls.)
      if (delta <= 0 || vrel.dot(n) >= 0) {
        delta = 0;
        return;
      }
      const Vec3 tilt = draw_tilt(p, n, vrel, true, stream);
      std::copy(tilt.data(), tilt.data() + 3, st);
      st[4] = double(stream.step);
      const Vec3 np = tilted_normal(n, st);
      const double start = std::min(delta, -vrel.dot(np) * dt);
      st[3] = np.dot(x - P.point) - r + start;
    } else if (enduring(p, m, st, stream.step, dt)) {
      // Settle onto a facet parallel to the wall, with the overlap (and energy) unchanged.
      const Vec3 old = tilted_normal(n, st);
      const double overlap = r - (old.dot(x - P.point) - st[3]);
      std::fill(st, st + 3, 0.0);
      st[3] = n.dot(x - P.point) - r + overlap;
    }
    const Vec3 np = tilted_normal(n, st);
    delta = r - (np.dot(x - P.point) - st[3]);
    n = np;
  }

  // v_ij.n (returned in vn) and the tangential velocity of the contact points (1.12), from the
  // relative velocity and the spins' part c_i w_i + c_j w_j, levers c along the line of centres.
  TSUBU_INLINE static L3 contact_velocity(L3 n, L3 vrel, L3 spin, double& vn) {
    vn = dot(vrel, n);
    if constexpr (kTangential) return vrel - vn * n - cross(spin, n);
    (void)spin;
    return {0, 0, 0};
  }
  TSUBU_INLINE static L3 spin_part(double ci, L3 wi, double cj, L3 wj) { return ci * wi + cj * wj; }
  TSUBU_INLINE static L3 approach(L3 n, L3 vrel, double ci, double cj, L3 wi, L3 wj, double& vn) {
    if constexpr (kTangential) return contact_velocity(n, vrel, spin_part(ci, wi, cj, wj), vn);
    (void)ci, (void)cj, (void)wi, (void)wj;
    return contact_velocity(n, vrel, {0, 0, 0}, vn);
  }

  // Everything the contact pass reads and writes, unpacked once per step.
  struct Pass {
    const double *x, *v, *w, *r, *m, *inv_i;
    const int* mat;
    const Id* ids;
    const Index *own, *par, *wown, *wall, *wnear;
    const double *cut2, *eta;
    double limit;  // max_overlap
    double *xi, *force, *nxft, *roll, *overlap, *rough;
    double *wxi, *wforce, *wnxft, *wroll, *woverlap, *wrough;
    std::uint8_t *touch, *wtouch;
    double* diss;
    std::uint8_t* loaded;
    const Plane* planes;
    const PairTable* table;
    const PairParams* same;  // the parameters of every pair when all spheres share a material
    std::uint64_t step, seed;
    double dt;

    // `ahead`: 1 where the pass evaluates the next step's contacts (fused_pass).
    Pass(Simulation& s, double dt_, long ahead = 0)
        : x(s.x_.data()), v(s.v_.data()), w(s.w_.data()), r(s.radius_.data()),
          m(s.mass_.data()), inv_i(s.inv_inertia_.data()), mat(s.material_.data()),
          ids(s.id_.data()), own(s.near_owner_.data()), par(s.near_partner_.data()),
          wown(s.wall_owner_.data()), wall(s.wall_index_.data()), wnear(s.wall_near_.data()),
          cut2(s.near_cut2_.data()), eta(s.near_eta_.data()), limit(s.opt_.max_overlap),
          xi(s.pair_xi_.data()), force(s.pair_force_.data()), nxft(s.pair_nxft_.data()),
          roll(s.pair_roll_.data()), overlap(s.pair_overlap_.data()),
          rough(s.pair_rough_.data()), wxi(s.wall_xi_.data()), wforce(s.wall_force_.data()),
          wnxft(s.wall_nxft_.data()), wroll(s.wall_roll_.data()),
          woverlap(s.wall_overlap_.data()), wrough(s.wall_rough_.data()),
          touch(s.pair_touch_.data()), wtouch(s.wall_touch_.data()),
          diss(s.dissipated_.data()), loaded(s.loaded_.data()), planes(s.planes_.data()), table(&s.pairs_),
          same(s.sphere_material_ >= 0 ? &s.pairs_(s.sphere_material_, s.sphere_material_) : nullptr),
          step(std::uint64_t(s.step_ + ahead)), seed(s.opt_.seed), dt(dt_) {}
  };

  // Ends a pair contact: its results go to zero and its spring energy is booked as lost.
  static double end_pair(const Pass& c, Index q, const PairParams& params, const Vec3& d,
                         double rs, double dist2) {
    double lost = 0;
    c.touch[q] = 0;
    c.overlap[q] = 0;
    vec3(c.force, q).setZero();
    if constexpr (kHistory) release(params.kt, c.xi + 3 * q, lost);
    if constexpr (kTangential || kRough) vec3(c.nxft, q).setZero();
    if constexpr (kRolling) vec3(c.roll, q).setZero();
    if constexpr (kRough) {
      if (params.roughness > 0) {  // a facet spring still loaded is lost with it
        const double o = rough_pair_overlap(c.rough + kRoughWidth * q, d, rs - std::sqrt(dist2));
        if (o > 0) lost += 0.5 * params.kn * o * o;
      }
    }
    (void)d;
    (void)rs;
    (void)dist2;
    return lost;
  }

  // One near-pair entry that touches or has just stopped touching. Returns the energy it lost
  // this step; raises `excess` to its overlap beyond
  // max_overlap x the smaller radius.
  TSUBU_INLINE static double pair_entry(const Pass& c, Index q, double inv_dist, double& excess) {
    const Index i = c.own[q], j = c.par[q];
    const double ri = c.r[i], rj = c.r[j], dt = c.dt;
    const Vec3 d = vec3(c.x, i) - vec3(c.x, j);
    const double rs = ri + rj;
    const double dist2 = dot(lanes(d), lanes(d));
    const PairParams& params = (*c.table)(c.mat[i], c.mat[j]);
    if (dist2 >= c.cut2[q]) return end_pair(c, q, params, d, rs, dist2);  // (1.10)
    ContactGeometry g;
    const double dist = dist2 * inv_dist;
    g.delta = rs - dist;
    const Vec3 n = d * inv_dist;
    g.n = n;
    excess = std::max(excess, g.delta - c.limit * std::min(ri, rj));
    g.eta_n = c.eta[q];
    if constexpr (kRough) g.m_eff = c.m[i] * c.m[j] / (c.m[i] + c.m[j]);
    const Vec3 vrel = vec3(c.v, i) - vec3(c.v, j);
    if constexpr (kTorque) {
      g.ci = ri - 0.5 * g.delta;
      g.cj = rj - 0.5 * g.delta;
    }
    bool tilted = false;
    if constexpr (kRough) {
      if (params.roughness > 0) {
        const ContactStream stream{c.seed, std::uint64_t(c.ids[i]), std::uint64_t(c.ids[j]),
                                   c.step};
        double virtual_overlap = 0;
        const Vec3 spin = (g.ci * vec3(c.w, i) + g.cj * vec3(c.w, j)).cross(n);
        g.n = rough_pair(params, n, d, g.delta, vrel, spin, g.m_eff, c.touch[q],
                         c.rough + kRoughWidth * q, stream, dt, virtual_overlap);
        if (!(virtual_overlap > 0))  // not (or no longer) pressed across the facet
          return c.touch[q] ? end_pair(c, q, params, d, rs, dist2) : 0.0;
        g.delta = virtual_overlap;
        tilted = true;
      }
    }
    if (!tilted) {
      const L3 vt = approach(lanes(n), lanes(vrel), g.ci, g.cj, lanes(vec3(c.w, i)),
                             lanes(vec3(c.w, j)), g.vn);
      if constexpr (kTangential) g.vt = vec(vt);
    } else {
      // Contact points on the line of centres; normal and tangential parts relative to n'.
      const Vec3 spin = (g.ci * vec3(c.w, i) + g.cj * vec3(c.w, j)).cross(n);
      const Vec3 vcp = vrel - spin;
      g.vn = vcp.dot(g.n);
      if constexpr (kTangential) g.vt = vcp - g.vn * g.n;
    }
    if constexpr (kRolling) {
      g.w_rel = vec3(c.w, i) - vec3(c.w, j);
      g.ri = ri;
      g.rj = rj;
      g.spin_mobility = ri * c.inv_i[i] + rj * c.inv_i[j];
    }
    ContactResult res = evaluate(g, params, dt, c.xi + 3 * q);
    c.touch[q] = 1;
    c.overlap[q] = rs - dist;  // geometric: it sets the levers c = r - overlap/2
    vec3(c.force, q) = res.force;
    // (1.19) with the contact-point lever c_i along the line of centres; with a tilted normal
    // the whole force has a moment about the centres (n x F), which keeps angular momentum exact.
    if constexpr (kTangential || kRough)
      vec3(c.nxft, q) = tilted ? Vec3(n.cross(res.force)) : res.n_cross_ft;
    if constexpr (kRolling) {
      vec3(c.roll, q) = res.roll;
      res.power -= res.roll.dot(ri * vec3(c.w, i) - rj * vec3(c.w, j));
    }
    return res.power * dt;
  }

  // A wall contact's approach along n at the contact point x_i - c n (lever c = r - delta/2,
  // set in `ci`): returns v_n; sets the tangential velocity (1.12) where the law has one.
  static double wall_approach(const Pass& c, const Plane& P, Index i, const Vec3& n, double delta,
                              double& ci, Vec3& vt) {
    ci = c.r[i] - 0.5 * delta;
    Vec3 vrel = vec3(c.v, i);
    if constexpr (MovingWalls) {
      const Vec3 contact = vec3(c.x, i) - ci * n;
      vrel -= P.velocity + P.angular_velocity.cross(contact - P.point);
    }
    const double vn = vrel.dot(n);
    if constexpr (kTangential) vt = vrel - vn * n - (ci * vec3(c.w, i)).cross(n);
    return vn;
  }

  // One near-wall entry that touches, or touched last step. Returns the energy it lost; raises
  // `excess` as pair_entry.
  static double wall_entry(const Pass& c, Index e, double& excess) {
    const Index i = c.wown[e];
    const Plane& P = c.planes[c.wall[e]];
    const PairParams& params = (*c.table)(c.mat[i], P.material);
    const Vec3 xi_pos = vec3(c.x, i);
    const double ri = c.r[i], dt = c.dt;
    double delta = ri - P.normal.dot(xi_pos - P.point);  // (3.1), signed: a half-space
    Vec3 n = P.normal;
    if constexpr (kRough) {
      if (params.roughness > 0) {
        Vec3 vw = vec3(c.v, i);
        if constexpr (MovingWalls)
          vw -= P.velocity + P.angular_velocity.cross(xi_pos - ri * n - P.point);
        const ContactStream stream{c.seed, std::uint64_t(c.ids[i]),
                                   ContactStream::kWallTag + std::uint64_t(c.wall[e]), c.step};
        rough_wall(params, P, xi_pos, ri, vw, c.m[i], c.wtouch[e], c.wrough + kRoughWidth * e,
                   stream, dt, n, delta);
      }
    }
    if (delta <= 0) {
      double lost = 0;
      if (c.wtouch[e]) {
        c.wtouch[e] = 0;
        c.woverlap[e] = 0;
        vec3(c.wforce, e).setZero();
        if constexpr (kHistory) release(params.kt, c.wxi + 3 * e, lost);
        if constexpr (kTangential) vec3(c.wnxft, e).setZero();
        if constexpr (kRolling) vec3(c.wroll, e).setZero();
      }
      return lost;
    }
    ContactGeometry g;
    g.n = n;
    g.delta = delta;
    excess = std::max(excess, delta - c.limit * ri);
    g.m_eff = c.m[i];
    g.eta_n = HookeNormal::damping(params, g.m_eff);
    g.cj = 0;
    g.vn = wall_approach(c, P, i, n, delta, g.ci, g.vt);
    if constexpr (kRolling) {
      g.w_rel = vec3(c.w, i);
      if constexpr (MovingWalls) g.w_rel -= P.angular_velocity;
      g.ri = ri;
      g.rj = 0;
      g.spin_mobility = ri * c.inv_i[i];
    }
    ContactResult res = evaluate(g, params, dt, c.wxi + 3 * e);
    c.wtouch[e] = 1;
    c.woverlap[e] = delta;
    vec3(c.wforce, e) = res.force;
    // The lever runs along the (facet) normal: the wall's surface.
    if constexpr (kTangential) vec3(c.wnxft, e) = res.n_cross_ft;
    if constexpr (kRolling) {
      vec3(c.wroll, e) = res.roll;
      res.power -= ri * res.roll.dot(g.w_rel);
    }
    return res.power * dt;
  }

  // Laws without rolling or roughness take the pairs a block at a time: a gather loop reads each
  // contact's geometry, velocities, parameters and history into a structure of arrays; one loop
  // runs the law's lane form over the block, which the compiler vectorises (AVX2: 4 contacts at
  // a time); a store loop writes the results back. The arithmetic is pair_entry's, so are the bits.
  static constexpr bool kBlocked = !kRolling && !kRough;
  static constexpr int kBlock = 64;
  struct alignas(64) Block {
    // Walls: normal, tangential and normal velocity. Pairs: relative velocity and the spins'
    // part (the rest of the geometry is the scan's), turned into n, v_t and v_n by the
    // vectorised loop.
    double nx[kBlock], ny[kBlock], nz[kBlock], vtx[kBlock], vty[kBlock], vtz[kBlock], vn[kBlock];
    double vrx[kBlock], vry[kBlock], vrz[kBlock], spx[kBlock], spy[kBlock], spz[kBlock];
    double delta[kBlock], eta[kBlock];
    double kn[kBlock], kt[kBlock], mu[kBlock], td[kBlock];
    double xix[kBlock], xiy[kBlock], xiz[kBlock];
    double fx[kBlock], fy[kBlock], fz[kBlock], tx[kBlock], ty[kBlock], tz[kBlock], power[kBlock];
    bool inside[kBlock];

    // One material for all spheres: the parameter lanes are filled once, not per contact.
    explicit Block(const PairParams* same) {
      // Zeros, so that the lanes past a block's end (evaluate_block) hold finite values.
      std::memset(static_cast<void*>(this), 0, sizeof *this);
      if (!same) return;
      std::fill(kn, kn + kBlock, same->kn);
      std::fill(kt, kt + kBlock, same->kt);
      std::fill(mu, mu + kBlock, same->friction);
      std::fill(td, td + kBlock, same->tangential_damping);
    }
  };

  // The pair entries of a chunk that are in contact or were last step, as the scan keeps them:
  // entry, x_i - x_j, its squared length and 1/|x_ij|.
  struct Scan {
    Index act[kBlock];
    double dx[kBlock], dy[kBlock], dz[kBlock], d2[kBlock], inv[kBlock];
  };

  // Entries s.act[0, len), len <= kBlock, as pair_entry for each, in order. Returns true if a
  // force is not finite.
  TSUBU_INLINE static bool pair_block(const Pass& c, const Scan& s, int len, Block& b,
                                      double& excess, double& fmax) {
    if (c.same)
      gather<true>(c, s, len, b, excess);
    else
      gather<false>(c, s, len, b, excess);
    const bool bad = evaluate_block<true>(b, s, len, c.dt, fmax);
    store(c, s.act, len, b);
    return bad;
  }

  template <bool kSame>
  static void gather(const Pass& c, const Scan& s, int len, Block& b, double& excess) {
    for (int a = 0; a < len; ++a) {
      const Index q = s.act[a], i = c.own[q], j = c.par[q];
      const double ri = c.r[i], rj = c.r[j];
      const double dist2 = s.d2[a], inv = s.inv[a];
      const double delta = (ri + rj) - dist2 * inv;
      const double ci = ri - 0.5 * delta, cj = rj - 0.5 * delta;
      const L3 vrel = lanes(vec3(c.v, i) - vec3(c.v, j));
      b.vrx[a] = vrel.x, b.vry[a] = vrel.y, b.vrz[a] = vrel.z;
      if constexpr (kTangential) {
        const L3 spin = spin_part(ci, lanes(vec3(c.w, i)), cj, lanes(vec3(c.w, j)));
        b.spx[a] = spin.x, b.spy[a] = spin.y, b.spz[a] = spin.z;
      }
      b.inside[a] = dist2 < c.cut2[q];  // (1.10); else the contact has just opened
      if (b.inside[a]) excess = std::max(excess, delta - c.limit * std::min(ri, rj));
      b.delta[a] = delta, b.eta[a] = c.eta[q];
      if constexpr (!kSame) {
        const PairParams& p = (*c.table)(c.mat[i], c.mat[j]);
        b.kn[a] = p.kn, b.kt[a] = p.kt, b.mu[a] = p.friction, b.td[a] = p.tangential_damping;
      }
      if constexpr (kHistory) {
        const double* xi = c.xi + 3 * q;
        b.xix[a] = xi[0], b.xiy[a] = xi[1], b.xiz[a] = xi[2];
      }
    }
  }

  // The law over lanes [0, len) of a block of pairs (kPairs: the normal from the scan's x_ij and
  // 1/|x_ij|, the velocities from the block's) or of walls (s unused). Returns true if a
  // contact's force is not finite.
  template <bool kPairs>
  [[gnu::noinline]] static bool evaluate_block(Block& __restrict b, const Scan& __restrict s,
                                               int len, double dt, double& fmax) {
    // With a 32-bit `bad`, gcc runs 8 lanes per vector iteration (two independent chains of
    // divisions and square roots, which the core overlaps) and the rest one at a time, each a
    // long serial chain: the block is run to the next multiple of 8 instead. The extra lanes
    // hold an earlier block's values (or zeros): their results are not read, not counted bad.
    static_assert(kBlock % 8 == 0);
    const int padded = (len + 7) & ~7;
    int bad = 0;
    std::uint64_t top;  // the largest |fx| + |fy| + |fz| (>= |F|), as bits: gcc vectorises that
    std::memcpy(&top, &fmax, sizeof top);
    for (int a = 0; a < padded; ++a) {
      L3 n, vt;
      double vn;
      if constexpr (kPairs) {
        n = s.inv[a] * L3{s.dx[a], s.dy[a], s.dz[a]};
        const L3 spin = kTangential ? L3{b.spx[a], b.spy[a], b.spz[a]} : L3{0, 0, 0};
        vt = contact_velocity(n, {b.vrx[a], b.vry[a], b.vrz[a]}, spin, vn);
      } else {
        n = {b.nx[a], b.ny[a], b.nz[a]};
        vt = {b.vtx[a], b.vty[a], b.vtz[a]};
        vn = b.vn[a];
      }
      L3 xi{b.xix[a], b.xiy[a], b.xiz[a]}, f, t{0, 0, 0};
      double power;
      Law::lane(n, vt, b.delta[a], vn, b.eta[a], {b.kn[a], b.kt[a], b.mu[a], b.td[a]}, dt, xi, f,
                t, power);
      b.xix[a] = xi.x, b.xiy[a] = xi.y, b.xiz[a] = xi.z;
      b.fx[a] = f.x, b.fy[a] = f.y, b.fz[a] = f.z;
      b.tx[a] = t.x, b.ty[a] = t.y, b.tz[a] = t.z;
      b.power[a] = power;
      const double sum = (f.x + f.y) + f.z;
      bad |= (sum - sum == 0 || a >= len) ? 0 : 1;  // inf or NaN (a just-opened lane's stay finite)
      const double size = (std::abs(f.x) + std::abs(f.y)) + std::abs(f.z);
      std::uint64_t bits;
      std::memcpy(&bits, &size, sizeof bits);
      top = top > bits ? top : bits;  // (the padding lanes' earlier forces too: a bound)
    }
    std::memcpy(&fmax, &top, sizeof top);
    return bad != 0;
  }

  // Where one kind of entry (near pairs, near walls) keeps its results.
  struct Results {
    std::uint8_t* touch;
    double *overlap, *force, *nxft, *xi;
  };

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
      if constexpr (kTangential) {
        double* t = r.nxft + 3 * q;
        t[0] = b.tx[a], t[1] = b.ty[a], t[2] = b.tz[a];
        double* xi = r.xi + 3 * q;
        xi[0] = b.xix[a], xi[1] = b.xiy[a], xi[2] = b.xiz[a];
      }
      lost = b.power[a] * dt;
    } else {
      r.touch[q] = 0;
      r.overlap[q] = 0;
      vec3(r.force, q).setZero();
      if constexpr (kHistory) release(b.kt[a], r.xi + 3 * q, lost);
      if constexpr (kTangential) vec3(r.nxft, q).setZero();
    }
    return lost;
  }

  static void store(const Pass& c, const Index* act, int len, const Block& b) {
    // The pointers as locals: the byte stores (touch, loaded) may alias anything in memory,
    // and gcc would reload each pointer from `c` after every one of them.
    const Results pairs{c.touch, c.overlap, c.force, c.nxft, c.xi};
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

  // Near-wall entries e[0, len) in contact or just released, as wall_entry for each, in order,
  // through the same block as pairs: the law's lanes take a wall as a partner with no radius,
  // no spin and the plane's material. Returns true if a force is not finite.
  static bool wall_block(const Pass& c, const Index* e, int len, Block& b, const Scan& scan,
                         double& excess, double& fmax) {
    for (int a = 0; a < len; ++a) {
      const Index i = c.wown[e[a]];
      const Plane& P = c.planes[c.wall[e[a]]];
      const PairParams& p = (*c.table)(c.mat[i], P.material);
      const Vec3 xi_pos = vec3(c.x, i);
      const double ri = c.r[i];
      const double delta = ri - P.normal.dot(xi_pos - P.point);  // (3.1), signed: a half-space
      b.inside[a] = delta > 0;
      if (b.inside[a]) excess = std::max(excess, delta - c.limit * ri);
      double ci;
      Vec3 vt = Vec3::Zero();
      const double vn = wall_approach(c, P, i, P.normal, delta, ci, vt);
      b.nx[a] = P.normal.x(), b.ny[a] = P.normal.y(), b.nz[a] = P.normal.z();
      b.vtx[a] = vt.x(), b.vty[a] = vt.y(), b.vtz[a] = vt.z();
      b.delta[a] = delta, b.vn[a] = vn, b.eta[a] = HookeNormal::damping(p, c.m[i]);
      b.kn[a] = p.kn, b.kt[a] = p.kt, b.mu[a] = p.friction, b.td[a] = p.tangential_damping;
      if constexpr (kHistory) {
        const double* xi = c.wxi + 3 * e[a];
        b.xix[a] = xi[0], b.xiy[a] = xi[1], b.xiz[a] = xi[2];
      }
    }
    const bool bad = evaluate_block<false>(b, scan, len, c.dt, fmax);  // (the scan is not read)
    const Results walls{c.wtouch, c.woverlap, c.wforce, c.wnxft, c.wxi};
    for (int a = 0; a < len; ++a) {
      const Index i = c.wown[e[a]];
      const double lost = store_lane(walls, e[a], b, a, c.dt);
      if (b.inside[a]) mark(c.loaded, i);
      if (lost != 0) c.diss[i] += lost;
    }
    return bad;
  }

  // [lo, hi) of part t of nt of an entry list sorted by owner, cut at owner boundaries, so that
  // each owner's entries (and its dissipation sum) belong to one thread.
  template <class Owner>
  static Index part_start(Owner&& owner, Index count, int t, int nt) {
    Index b = Index((std::int64_t(count) * t) / nt);
    while (b > 0 && b < count && owner(b - 1) == owner(b)) --b;
    return b;
  }

  // Scans entries [lo, hi) without branches, keeping in `act` those that pass `keep`; returns
  // how many.
  template <class Keep>
  static Index compact(Index lo, Index hi, Index* act, Keep&& keep) {
    Index count = 0;
    for (Index q = lo; q < hi; ++q) {
      act[count] = q;
      count += keep(q) ? 1 : 0;
    }
    return count;
  }

  // The same for pairs; the separations found on the way are kept for the law.
  static Index compact_pairs(const Pass& c, Index lo, Index hi, Scan& s) {
    Index count = 0;
    for (Index q = lo; q < hi; ++q) {
      const L3 d = lanes(vec3(c.x, c.own[q]) - vec3(c.x, c.par[q]));
      const double dd = dot(d, d);
      s.act[count] = q;
      s.dx[count] = d.x, s.dy[count] = d.y, s.dz[count] = d.z, s.d2[count] = dd;
      count += ((dd < c.cut2[q]) | (c.touch[q] != 0)) ? 1 : 0;
    }
    return count;
  }

  // In a large scene the scan waits on memory for the partners' positions (a partner sits up to
  // a layer of cells further down the array; in the fused pass, up to two layers back, in the
  // last level of cache) and the store on the owners' dissipation sums. Those of a chunk two
  // chunks ahead are requested while this one is scanned (1.04x on the drop at N = 1e6 in two
  // passes, ~1.1x fused; none below kFar particles, whose data stay in cache). Not inlined:
  // inlined, the branch that skips it cost the dense bed 0.3 % more instructions through a
  // different allocation of registers.
  static constexpr std::size_t kFar = std::size_t(1) << 16;
  [[gnu::noinline]] static void prefetch_partners(const Pass& c, Index lo, Index hi) {
    for (Index q = lo; q < hi; ++q) {
      __builtin_prefetch(c.x + 3 * std::size_t(c.par[q]));
      __builtin_prefetch(c.diss + c.own[q], 1);
    }
  }

  // 1/|x_ij| of every kept pair, in one pass that the compiler vectorises: the square roots and
  // divisions then leave the contact law's critical path.
  [[gnu::noinline]] static void inverse_distances(Scan& s, Index count) {
    for (Index a = 0; a < count; ++a) s.inv[a] = 1.0 / std::sqrt(s.d2[a]);
  }

  // Flags particle k as having a contact this step (threads may flag the same one).
  static void mark(std::uint8_t* loaded, Index k) { __atomic_store_n(loaded + k, 1, __ATOMIC_RELAXED); }

  // What evaluating contacts found, for one thread or reduced over all: the largest overlap
  // beyond max_overlap x the smaller radius, whether a result is not finite, and the largest
  // |fx| + |fy| + |fz| of a contact force (for fusable()).
  struct Found {
    double excess = 0, fmax = 0;
    int bad = 0;
  };

  // Near-pair entries [lo, hi), whole owners, a chunk of kBlock at a time: the particles the scan
  // reads are still in the nearest cache when the contacts among them are evaluated. `far`: the
  // partners' positions are requested two chunks ahead.
  [[gnu::noinline]] static void pair_range(const Pass& c, Index lo, Index hi, bool far, Scan& scan,
                                           Block& block, Found& f) {
    for (Index base = lo; base < hi; base += kBlock) {
      if (far) prefetch_partners(c, std::min(hi, base + 2 * kBlock), std::min(hi, base + 3 * kBlock));
      const Index count = compact_pairs(c, base, std::min<Index>(hi, base + kBlock), scan);
      inverse_distances(scan, count);
      if constexpr (kBlocked) {
        if (pair_block(c, scan, int(count), block, f.excess, f.fmax)) f.bad = 1;
      } else {
        for (Index a = 0; a < count; ++a) {
          const Index q = scan.act[a];
          const double lost = pair_entry(c, q, scan.inv[a], f.excess);
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

  static void note_force(const Eigen::Map<Vec3>& force, Found& f) {
    const double sum = force.sum();
    if (!(sum - sum == 0)) f.bad = 1;  // inf or NaN (Eigen's allFinite() is not inlined)
    f.fmax = std::max(f.fmax, force.cwiseAbs().sum());
  }

  // Part t of nt of the near-wall entries in contact or just released; after every pair, so that
  // an owner's dissipation sum keeps one order.
  static void wall_part(const Pass& c, Index* wact, Index nw, int t, int nt, Scan& scan,
                        Block& block, Found& f) {
    auto wall_owner = [&](Index p) { return c.wown[c.wnear[p]]; };
    const Index wlo = part_start(wall_owner, nw, t, nt), whi = part_start(wall_owner, nw, t + 1, nt);
    const Index wcount = compact(wlo, whi, wact + wlo, [&](Index p) {
      const Index e = c.wnear[p];
      const Plane& P = c.planes[c.wall[e]];
      const double gap = P.normal.dot(vec3(c.x, c.wown[e]) - P.point) - c.r[c.wown[e]];
      return (gap < 0) | (c.wtouch[e] != 0);
    });
    if constexpr (kBlocked) {
      Index e[kBlock];
      for (Index a0 = 0; a0 < wcount; a0 += kBlock) {
        const int len = int(std::min<Index>(kBlock, wcount - a0));
        for (int a = 0; a < len; ++a) e[a] = c.wnear[wact[wlo + a0 + a]];
        if (wall_block(c, e, len, block, scan, f.excess, f.fmax)) f.bad = 1;
      }
    } else {
      for (Index a = 0; a < wcount; ++a) {
        const Index e = c.wnear[wact[wlo + a]];
        const double lost = wall_entry(c, e, f.excess);
        if (lost != 0) c.diss[c.wown[e]] += lost;
        if (c.wtouch[e]) mark(c.loaded, c.wown[e]);
        note_force(vec3(c.wforce, e), f);
      }
    }
  }

  // Inside a parallel region: this thread's number, the team's size and its part [lo, hi) of n
  // particles (contiguous, in order of thread number).
  struct Share {
    int t, nt;
    Index lo, hi;
  };
  static Share share(Index n) {
#ifdef _OPENMP
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
#else
    const int t = 0, nt = 1;
#endif
    return {t, nt, Index(std::int64_t(n) * t / nt), Index(std::int64_t(n) * (t + 1) / nt)};
  }

  // Pass 1: every near pair and near-wall entry in contact, or that was in contact last step,
  // is evaluated (or ended) and its result stored with it; each owner books the energy its
  // entries lost.
  static Found contact_pass(Simulation& s, double dt) {
    const Pass c(s, dt);
    const Index np = Index(s.near_partner_.size()), nw = Index(s.wall_near_.size());
    const int threads = static_cast<int>(s.n_) >= s.opt_.parallel_min ? s.threads() : 1;
    const bool far = s.n_ >= kFar;
    double excess = 0, fmax = 0;
    int bad = 0;
#pragma omp parallel num_threads(threads) reduction(max : excess, fmax, bad)
    {
      const Share me = share(0);
      auto pair_owner = [&](Index q) { return c.own[q]; };
      Scan scan{};
      Block block(c.same);
      Found f;
      pair_range(c, part_start(pair_owner, np, me.t, me.nt),
                 part_start(pair_owner, np, me.t + 1, me.nt), far, scan, block, f);
#pragma omp barrier
      wall_part(c, s.active_.data(), nw, me.t, me.nt, scan, block, f);
      excess = f.excess, fmax = f.fmax, bad = f.bad;
    }
    return {excess, fmax, bad};
  }

  // v += dt g, x += dt v over particles [lo, hi); returns max |v|^2 and a sum that is not
  // finite if a velocity is not. Outside any OpenMP region, with local accumulators and the
  // maximum taken on the bits (an order-preserving integer for doubles >= 0), so that gcc
  // vectorises it.
  [[gnu::noinline]] static void drift(double* x, double* v, Index lo, Index hi, double dt,
                                     const double gx, const double gy, const double gz,
                                     double& vmax2, double& check) {
    std::uint64_t top = 0;
    double sum = 0;
    for (Index k = lo; k < hi; ++k) {
      const double vx = v[3 * k] + gx, vy = v[3 * k + 1] + gy, vz = v[3 * k + 2] + gz;
      v[3 * k] = vx;
      v[3 * k + 1] = vy;
      v[3 * k + 2] = vz;
      x[3 * k] += dt * vx;
      x[3 * k + 1] += dt * vy;
      x[3 * k + 2] += dt * vz;
      const double v2 = vx * vx + vy * vy + vz * vz;
      std::uint64_t bits;
      std::memcpy(&bits, &v2, sizeof bits);
      top = top > bits ? top : bits;
      sum += v2 * 0.0;  // NaN if v2 is not finite
    }
    std::memcpy(&vmax2, &top, sizeof top);
    check = sum;
  }

  // Pass 2, over particles (2.2), a chunk of kChunk particles at a time: the particles of the
  // chunk with an entry in contact sum their contacts (ContactSums, order fixed by ids) into
  // v += dt F/m, w += dt T/I; then a dense pass over the chunk adds gravity and moves it,
  // v += dt g, x += dt v (the chunk's velocities are still in the nearest cache), and bounds the
  // distance moved for the neighbour lists by dt max|v|. Returns true if a new velocity is not
  // finite.
  static constexpr Index kChunk = 2048, kAhead = 8;

  // The sums of a run of busy particles from the flat entry list (Simulation::sum_entry_):
  // entries [p0, p1) in one loop, each adding its force (and n x F_t moment) to its particle's
  // running sum, which restarts at zero at a particle's first entry; the running sums go to
  // out[8 slot] (F in 0-2, T in 4-6), slot counting the particles from 0. The same additions in
  // the same order as ContactSums::at, so the same bits, without the three short loops per
  // particle whose exits the branch predictor misses (13 % off the dense bed's particle pass).
  static constexpr bool kFlatSums = !kRolling && (kTangential || !kRough);
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

  [[gnu::noinline]] static void flat_sums(const std::uint32_t* __restrict entry, Index p0, Index p1,
                                          const ContactSums& sums, const double* rads,
                                          double* __restrict out) {
    // Indexed by the kind, so that the loop has no branch for gcc to guess: the arrays read,
    // the sign of the force (F - f is F + (-f), bit for bit).
    const double* force[4] = {sums.pf, sums.pf, sums.wf, sums.wf};
    const double* moment[4] = {sums.pn, sums.pn, sums.wn, sums.wn};
    const double* overlap[4] = {sums.po, sums.po, sums.wo, sums.wo};
    const double sign[4] = {1.0, -1.0, 1.0, 1.0};
    std::int64_t slot = -1;
    V4 F{0, 0, 0, 0}, T{0, 0, 0, 0};
    for (const std::uint32_t *p = entry + p0, *end = entry + p1; p < end; ++p) {
      const std::uint32_t u = *p, kind = u & 3u;
      const std::size_t e = u >> 3;
      const std::int64_t first = (u >> 2) & 1u;
      const M4 keep = M4{} + (first - 1);  // all ones but at a particle's first entry: from +0
      slot += first;
      F = V4(M4(F) & keep) + sign[kind] * load4(force[kind] + 3 * e);
      std::memcpy(out + 8 * slot, &F, sizeof F);
      if constexpr (kTangential) {  // (1.19): both sides of a pair take -(r - overlap/2) n x F_t
        const double lever = rads[slot] - 0.5 * overlap[kind][e];
        T = V4(M4(T) & keep) - lever * load4(moment[kind] + 3 * e);
        std::memcpy(out + 8 * slot + 4, &T, sizeof T);
      }
    }
  }

  // The particle pass's view of the scene, unpacked once per pass.
  struct Mover {
    double *x, *v, *w;
    const double *inv_m, *inv_i, *radius;
    const Index* busy;
    Index nb;
    std::uint8_t* loaded;
    ContactSums sums;
    const std::uint32_t* sum_entry;
    const Index* sum_offset;
    bool flat;
    double dt, gx, gy, gz;

    Mover(Simulation& s, double dt_)
        : x(s.x_.data()), v(s.v_.data()), w(s.w_.data()), inv_m(s.inv_mass_.data()),
          inv_i(s.inv_inertia_.data()), radius(s.radius_.data()), busy(s.busy_.data()),
          nb(Index(s.busy_.size())), loaded(s.loaded_.data()), sums(s),
          sum_entry(s.sum_entry_.data()), sum_offset(s.sum_offset_.data()),
          flat(s.sum_offset_.size() == std::size_t(nb) + 1), dt(dt_),
          gx(dt_ * s.opt_.gravity.x()), gy(dt_ * s.opt_.gravity.y()), gz(dt_ * s.opt_.gravity.z()) {}

    // The first busy particle at or after particle k.
    Index first_busy(Index k) const { return Index(std::lower_bound(busy, busy + nb, k) - busy); }

    // Particles [c0, c1) (at most kChunk), whose busy ones start at busy[b] (b is moved past
    // them): kicks and drift. Raises vmax2 to max |v|^2; adds to `check` 0, or NaN if a new
    // velocity is not finite.
    void chunk(Index c0, Index c1, Index& b, double& vmax2, double& check) const {
      // Locals, and a lambda that captures them by value: the byte store to `loaded` may alias
      // anything in memory, and gcc would reload every member or captured reference after it.
      double *const v = this->v, *const w = this->w;
      const double *const inv_m = this->inv_m, *const inv_i = this->inv_i;
      std::uint8_t* const loaded = this->loaded;
      const Index* const busy = this->busy;
      const double dt = this->dt;
      // Particle k in contact takes its sums: v += dt F/m, w += dt T/I. Returns 0, or NaN if
      // the new spin is not finite.
      auto kick = [=](Index k, const auto& F, const auto& T) {
        loaded[k] = 0;
        vec3(v, k) += (dt * inv_m[k]) * F;
        if constexpr (kTorque) {
          const Vec3 wk = vec3(w, k) + (dt * inv_i[k]) * T;
          vec3(w, k) = wk;
          return wk.sum() * 0.0;
        }
        return 0.0;
      };
      double kicked = 0;
      // The chunk's particles in contact, listed without branches; then their sums, each
      // prefetching the offsets and velocities of the particle kAhead places further down the
      // list (at N = 1e6 the particles in contact are a few per cent, scattered, and each read
      // would otherwise wait on memory).
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
      if (kFlatSums && flat && 2 * count >= b - b0) {
        for (Index r0 = b0; r0 < b; r0 += kFlatRun) {
          const Index r1 = std::min(b, r0 + kFlatRun);
          double rads[kFlatRun], out[8 * kFlatRun];
          for (Index a = r0; a < r1; ++a) rads[a - r0] = radius[busy[a]];
          flat_sums(sum_entry, sum_offset[r0], sum_offset[r1], sums, rads, out);
          for (Index a = r0; a < r1; ++a) {
            const double* o = out + 8 * (a - r0);
            if (loaded[busy[a]])
              kicked += kick(busy[a], Eigen::Map<const Vec3>(o), Eigen::Map<const Vec3>(o + 4));
          }
        }
        count = 0;
      }
      for (Index a = 0; a < count; ++a) {
        if (a + kAhead < count) sums.prefetch(list[a + kAhead], v, w);
        const Index k = list[a];
        Vec3 F = Vec3::Zero(), T = Vec3::Zero();
        sums.template at<kTangential, kTangential || kRough, kRolling>(k, F, T);
        kicked += kick(k, F, T);
      }
      double part_vmax2 = 0, part_check = 0;
      drift(x, v, c0, c1, dt, gx, gy, gz, part_vmax2, part_check);
      vmax2 = std::max(vmax2, part_vmax2);
      check += part_check + kicked;
    }
  };

  // Adds the distance any particle moved this step, dt max|v|, to the neighbour lists' bounds.
  static void book_moved(Simulation& s, double dt, double vmax2) {
    const double moved = std::sqrt(vmax2) * dt;
    s.moved_ += moved;
    s.moved_near_ += moved;
  }

  // Returns true if a new velocity is not finite; sets vmax2 to max |v|^2.
  static bool particle_pass(Simulation& s, double dt, double& vmax2_out) {
    const Mover mv(s, dt);
    const Index n = static_cast<Index>(s.n_);
    const int threads = n >= s.opt_.parallel_min ? s.threads() : 1;
    double vmax2 = 0, check = 0;
#pragma omp parallel num_threads(threads) reduction(max : vmax2) reduction(+ : check)
    {
      const Share me = share(n);
      Index b = mv.first_busy(me.lo);
      for (Index c0 = me.lo; c0 < me.hi; c0 += kChunk)
        mv.chunk(c0, std::min(me.hi, c0 + kChunk), b, vmax2, check);
    }
    book_moved(s, dt, vmax2);
    vmax2_out = vmax2;
    return !(check == 0);
  }

  // Fused pass (large scenes): the particle pass of this step and the pairs of the next step's
  // contact pass in one sweep over the particles, so that the contacts find their particles in
  // cache instead of memory. A pair owned by particle i is evaluated as soon as every particle
  // within the near list's reach of i has moved; owners whose partners lie in another thread's
  // part wait for a barrier; the walls follow all pairs, as in contact_pass. The same
  // arithmetic on the same entries as the two passes, in the same order per owner: the same
  // bits. Only for steps after which no neighbour list can be due (fusable()). Returns true if a
  // new velocity is not finite; sets vmax2 to max |v|^2 and `next` to the next step's findings.
  static bool fused_pass(Simulation& s, double dt, double& vmax2_out, Found& next) {
    const Mover mv(s, dt);
    const Pass c(s, dt, 1);
    const Index n = static_cast<Index>(s.n_), nw = Index(s.wall_near_.size());
    const Index below = s.near_reach_below_, above = s.near_reach_above_;
    const Index* owned = s.near_offset_.data();
    const int threads = n >= s.opt_.parallel_min ? s.threads() : 1;
    double vmax2 = 0, check = 0, excess = 0, fmax = 0;
    int bad = 0;
#pragma omp parallel num_threads(threads) reduction(max : vmax2, excess, fmax, bad) \
    reduction(+ : check)
    {
      const auto [t, nt, lo, hi] = share(n);
      // Owners in [ilo, ihi) have all their partners in [lo, hi).
      const Index ilo = t == 0 ? lo : std::min(hi, lo + below);
      const Index ihi = t == nt - 1 ? hi : std::max(ilo, hi - above);
      Scan scan{};
      Block block(c.same);
      Found f;
      Index b = mv.first_busy(lo), done = ilo;  // owners [ilo, done) evaluated
      for (Index c0 = lo; c0 < hi; c0 += kChunk) {
        const Index c1 = std::min(hi, c0 + kChunk);
        mv.chunk(c0, c1, b, vmax2, check);
        const Index ready = std::min(ihi, c1 - above);  // every partner of an owner below has moved
        if (ready > done) {
          pair_range(c, owned[done], owned[ready], true, scan, block, f);
          done = ready;
        }
      }
      pair_range(c, owned[done], owned[ihi], true, scan, block, f);
#pragma omp barrier
      pair_range(c, owned[lo], owned[ilo], true, scan, block, f);
      pair_range(c, owned[ihi], owned[hi], true, scan, block, f);
#pragma omp barrier
      wall_part(c, s.active_.data(), nw, t, nt, scan, block, f);
      excess = f.excess, fmax = f.fmax, bad = f.bad;
    }
    book_moved(s, dt, vmax2);
    vmax2_out = vmax2;
    next = {excess, fmax, bad};
    return !(check == 0);
  }

  // Whether runs of this scene fuse steps where they can.
  static bool fuses(const Simulation& s) { return kBlocked && !MovingWalls && s.n_ >= kFar; }

  // Whether this step may be fused with the next step's contact pass: no neighbour list can be
  // due after it. Any particle's new speed is at most its old one plus dt (|g| + the most
  // entries it sums x the largest contact force / the smallest mass); the step then moves no
  // particle further than dt times that (the factor 1 + 1e-9 covers rounding).
  static bool fusable(const Simulation& s, double dt, double vmax2, const Found& now,
                      double min_mass) {
    const double speed = std::sqrt(vmax2) + dt * (s.opt_.gravity.norm() +
                                                   double(s.max_entries_) * now.fmax / min_mass);
    const double step = dt * speed * (1 + 1e-9);
    return s.list_valid_ && !s.opt_.rebuild_every_step && std::isfinite(step) &&
           2.0 * (s.moved_ + step) <= s.list_skin_ && 2.0 * (s.moved_near_ + step) <= s.near_skin();
  }
};

}  // namespace tsubu::detail
