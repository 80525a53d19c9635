// The time loop, written once as a template over the contact law and the wall motion. Each
// specialisation is instantiated in registry.cpp; a run picks one when it starts.
//
// One step (symplectic Euler, 2.2) is two parallel passes: a contact pass over owners (forces
// from x^n, v^n, w^n, history updated, each owner's share summed), then a pass over particles
// that adds the reactions and advances v^{n+1} = v^n + dt F/m, w^{n+1} = w^n + dt T/I,
// x^{n+1} = x^n + dt v^{n+1}. Every particle's sum runs over its partners in an order fixed by
// ids, so results are bit-identical for any thread count and any rebuild schedule.
#pragma once
#include <algorithm>
#include <cmath>

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
    for (long k = 0; k < steps; ++k) {
      if (s.needs_rebuild()) s.rebuild(true);
      clock.lap(Phase::Neighbors);
      double worst = 0;
      const bool bad = contact_pass(s, dt, worst);
      clock.lap(Phase::Contacts);
      if (!(worst <= s.opt_.max_overlap)) s.report_overlap(dt);
      if (bad) s.report_nonfinite();
      if (finish_pass(s, dt)) s.report_nonfinite_velocity();
      if constexpr (MovingWalls) s.move_planes(dt);
      ++s.step_;
      s.time_ += dt;
      clock.lap(Phase::Integrate);
    }
  }

  // A contact that opens loses the energy still stored in its tangential spring.
  static void release(const PairParams& p, double* xi, double& dissipated) {
    const double u2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
    if (u2 == 0) return;
    dissipated += 0.5 * p.kt * u2;
    std::fill(xi, xi + 3, 0.0);
  }

  // Evaluates the law on geometry g with the entry's stored history; returns the result.
  static ContactResult evaluate(const ContactGeometry& g, const PairParams& p, double dt,
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

  // Pass 1, over owners: every pair entry (owned by the lower id) and every near-wall entry is
  // evaluated; each entry's result is stored for its partner, and the owner's own share is
  // summed in registers (partners in ascending id order, then walls) into f_, t_. Each entry
  // and each owner is written by one thread only. Returns true if some owner's sum is not
  // finite (which catches any non-finite contact force).
  static bool contact_pass(Simulation& s, double dt, double& worst_out) {
    const Index n = static_cast<Index>(s.n_);
    const double *x = s.x_.data(), *v = s.v_.data(), *w = s.w_.data();
    const double *r = s.radius_.data(), *m = s.mass_.data(), *inv_i = s.inv_inertia_.data();
    const int* mat = s.material_.data();
    const Index *off = s.pair_offset_.data(), *partner = s.pair_partner_.data();
    double *xi = s.pair_xi_.data(), *force = s.pair_force_.data(), *nxft = s.pair_nxft_.data();
    double *roll = s.pair_roll_.data(), *overlap = s.pair_overlap_.data();
    const Index *woff = s.wall_offset_.data(), *wall = s.wall_index_.data();
    double *wxi = s.wall_xi_.data(), *wforce = s.wall_force_.data();
    double *wnxft = s.wall_nxft_.data(), *wroll = s.wall_roll_.data();
    double* woverlap = s.wall_overlap_.data();
    std::uint8_t *touch = s.pair_touch_.data(), *wtouch = s.wall_touch_.data();
    double *rough = s.pair_rough_.data(), *wrough = s.wall_rough_.data();
    const Id* ids = s.id_.data();
    const std::uint64_t step = std::uint64_t(s.step_), seed = s.opt_.seed;
    double *f = s.f_.data(), *t = s.t_.data(), *diss = s.dissipated_.data();
    const Plane* planes = s.planes_.data();
    const PairTable& table = s.pairs_;
    double worst = 0;
    int bad = 0;
#pragma omp parallel for schedule(static) num_threads(s.threads()) if (n >= s.opt_.parallel_min) reduction(max : worst, bad)
    for (Index i = 0; i < n; ++i) {
      const Vec3 xi_pos = vec3(x, i);
      const double ri = r[i];
      Vec3 F = Vec3::Zero(), T = Vec3::Zero();
      double lost = 0;
      for (Index e = off[i]; e < off[i + 1]; ++e) {
        const Index j = partner[e];
        const Vec3 d = xi_pos - vec3(x, j);
        const double rs = ri + r[j];
        const double dist2 = d.squaredNorm();
        if (dist2 >= rs * rs) {  // (1.10): no contact; the history ends with it
          if (touch[e]) {
            touch[e] = 0;
            overlap[e] = 0;
            const PairParams& params = table(mat[i], mat[j]);
            if constexpr (kHistory) release(params, xi + 3 * e, lost);
            if constexpr (kRough) {
              if (params.roughness > 0) {  // a facet spring still loaded is lost with it
                const double o = rough_pair_overlap(rough + kRoughWidth * e, d,
                                                    rs - std::sqrt(dist2));
                if (o > 0) lost += 0.5 * params.kn * o * o;
              }
            }
          }
          continue;
        }
        ContactGeometry g;
        const double dist = std::sqrt(dist2);
        g.delta = rs - dist;
        const Vec3 n = d / dist;
        g.n = n;
        worst = std::max(worst, g.delta / std::min(ri, r[j]));
        g.m_eff = m[i] * m[j] / (m[i] + m[j]);
        const PairParams& params = table(mat[i], mat[j]);
        const Vec3 vrel = vec3(v, i) - vec3(v, j);
        if constexpr (kTorque) {
          g.ci = ri - 0.5 * g.delta;
          g.cj = r[j] - 0.5 * g.delta;
        }
        bool tilted = false;
        double* st = nullptr;
        if constexpr (kRough) {
          if (params.roughness > 0) {
            st = rough + kRoughWidth * e;
            const ContactStream stream{seed, std::uint64_t(ids[i]), std::uint64_t(ids[j]), step};
            double virtual_overlap = 0;
            const Vec3 spin = (g.ci * vec3(w, i) + g.cj * vec3(w, j)).cross(n);
            g.n = rough_pair(params, n, d, g.delta, vrel, spin, g.m_eff, touch[e], st, stream, dt,
                             virtual_overlap);
            if (!(virtual_overlap > 0)) {  // not (or no longer) pressed across the facet
              if (touch[e]) {
                touch[e] = 0;
                overlap[e] = 0;
                if constexpr (kHistory) release(params, xi + 3 * e, lost);
              }
              continue;
            }
            g.delta = virtual_overlap;
            tilted = true;
          }
        }
        if (!tilted) {
          g.vn = vrel.dot(n);
          if constexpr (kTangential)
            g.vt = vrel - g.vn * n - (g.ci * vec3(w, i) + g.cj * vec3(w, j)).cross(n);
        } else {
          // Contact points on the line of centres; normal and tangential parts relative to n'.
          const Vec3 spin = (g.ci * vec3(w, i) + g.cj * vec3(w, j)).cross(n);
          const Vec3 vcp = vrel - spin;
          g.vn = vcp.dot(g.n);
          if constexpr (kTangential) g.vt = vcp - g.vn * g.n;
        }
        if constexpr (kRolling) {
          g.w_rel = vec3(w, i) - vec3(w, j);
          g.ri = ri;
          g.rj = r[j];
          g.spin_mobility = ri * inv_i[i] + r[j] * inv_i[j];
        }
        ContactResult res = evaluate(g, params, dt, xi + 3 * e);
        touch[e] = 1;
        overlap[e] = rs - dist;  // geometric: it sets the levers c = r - overlap/2
        vec3(force, e) = res.force;
        F += res.force;
        if constexpr (kTangential || kRough) {
          // (1.19) with the contact-point lever c_i along the line of centres; with a tilted
          // normal the whole force has a moment about the centres (n x F), which keeps
          // angular momentum exact.
          const Vec3 nxf = tilted ? Vec3(n.cross(res.force)) : res.n_cross_ft;
          vec3(nxft, e) = nxf;
          T -= g.ci * nxf;
        }
        if constexpr (kRolling) {
          vec3(roll, e) = res.roll;
          T += ri * res.roll;  // (1.20)
          res.power -= res.roll.dot(ri * vec3(w, i) - r[j] * vec3(w, j));
        }
        lost += res.power * dt;  // the owner books the pair's dissipation
      }
      for (Index e = woff[i]; e < woff[i + 1]; ++e) {
        const Plane& P = planes[wall[e]];
        const PairParams& params = table(mat[i], P.material);
        double delta = ri - P.normal.dot(xi_pos - P.point);  // (3.1), signed: a half-space
        Vec3 n = P.normal;
        if constexpr (kRough) {
          if (params.roughness > 0) {
            Vec3 vw = vec3(v, i);
            if constexpr (MovingWalls)
              vw -= P.velocity + P.angular_velocity.cross(xi_pos - ri * n - P.point);
            const ContactStream stream{seed, std::uint64_t(ids[i]),
                                       ContactStream::kWallTag + std::uint64_t(wall[e]), step};
            rough_wall(params, P, xi_pos, ri, vw, m[i], wtouch[e], wrough + kRoughWidth * e,
                       stream, dt, n, delta);
          }
        }
        if (delta <= 0) {
          if (wtouch[e]) {
            wtouch[e] = 0;
            woverlap[e] = 0;
            if constexpr (kHistory) release(params, wxi + 3 * e, lost);
          }
          continue;
        }
        ContactGeometry g;
        g.n = n;
        g.delta = delta;
        worst = std::max(worst, delta / ri);
        g.m_eff = m[i];
        g.ci = ri - 0.5 * delta;
        g.cj = 0;
        Vec3 vrel = vec3(v, i);
        if constexpr (MovingWalls) {
          const Vec3 contact = xi_pos - g.ci * g.n;
          vrel -= P.velocity + P.angular_velocity.cross(contact - P.point);
        }
        g.vn = vrel.dot(g.n);
        if constexpr (kTangential) g.vt = vrel - g.vn * g.n - (g.ci * vec3(w, i)).cross(g.n);
        if constexpr (kRolling) {
          g.w_rel = vec3(w, i);
          if constexpr (MovingWalls) g.w_rel -= P.angular_velocity;
          g.ri = ri;
          g.rj = 0;
          g.spin_mobility = ri * inv_i[i];
        }
        ContactResult res = evaluate(g, params, dt, wxi + 3 * e);
        wtouch[e] = 1;
        woverlap[e] = delta;
        vec3(wforce, e) = res.force;
        F += res.force;
        if constexpr (kTangential) {
          vec3(wnxft, e) = res.n_cross_ft;
          T -= g.ci * res.n_cross_ft;  // lever along the (facet) normal: the wall's surface
        }
        if constexpr (kRolling) {
          vec3(wroll, e) = res.roll;
          T += ri * res.roll;
          res.power -= ri * res.roll.dot(g.w_rel);
        }
        lost += res.power * dt;
      }
      vec3(f, i) = F;
      if constexpr (kTorque) vec3(t, i) = T;
      if (lost != 0) diss[i] += lost;
      const double sum = F.sum() + T.sum();
      if (!(sum - sum == 0)) bad = 1;  // inf or NaN (Eigen's allFinite() is not inlined)
    }
    worst_out = worst;
    return bad != 0;
  }

  // Pass 2, over particles: adds the reactions of the entries where the particle is the
  // partner (owners in ascending id order) to its own sum, stores the total in f_, t_, and
  // advances it (2.2): v += dt (F/m + g), w += dt T/I, x += dt v. Returns true if a new
  // velocity is not finite.
  static bool finish_pass(Simulation& s, double dt) {
    const Index n = static_cast<Index>(s.n_);
    double *x = s.x_.data(), *v = s.v_.data(), *w = s.w_.data();
    double *f = s.f_.data(), *t = s.t_.data();
    const double *xr = s.x_ref_.data(), *r = s.radius_.data();
    const double *inv_m = s.inv_mass_.data(), *inv_i = s.inv_inertia_.data();
    const Index *roff = s.rev_offset_.data(), *rent = s.rev_entry_.data();
    const double *pf = s.pair_force_.data(), *pt = s.pair_nxft_.data(), *pr = s.pair_roll_.data();
    const double* po = s.pair_overlap_.data();
    const std::uint8_t* touch = s.pair_touch_.data();
    const Vec3 g = s.opt_.gravity;
    double md = 0;
    int bad = 0;
#pragma omp parallel for schedule(static) num_threads(s.threads()) if (n >= s.opt_.parallel_min) reduction(max : md, bad)
    for (Index k = 0; k < n; ++k) {
      Vec3 F = vec3(f, k);
      Vec3 T = kTorque ? Vec3(vec3(t, k)) : Vec3::Zero();
      const double rk = r[k];
      for (Index q = roff[k]; q < roff[k + 1]; ++q) {
        const Index e = rent[q];
        if (!touch[e]) continue;
        F -= vec3(pf, e);
        if constexpr (kTangential || kRough) T -= (rk - 0.5 * po[e]) * vec3(pt, e);
        if constexpr (kRolling) T -= rk * vec3(pr, e);
      }
      vec3(f, k) = F;
      Vec3 vk = vec3(v, k) + dt * (F * inv_m[k] + g);
      vec3(v, k) = vk;
      if constexpr (kTorque) {
        vec3(t, k) = T;
        vec3(w, k) += (dt * inv_i[k]) * T;
      }
      const Vec3 xk = vec3(x, k) + dt * vk;
      vec3(x, k) = xk;
      md = std::max(md, (xk - vec3(xr, k)).squaredNorm());
      const double sum = vk.sum();
      if (!(sum - sum == 0)) bad = 1;
    }
    s.max_disp2_ = md;
    return bad != 0;
  }
};

}  // namespace tsubu::detail
