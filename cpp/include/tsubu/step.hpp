// The time loop, written once as a template over the contact law and the wall motion. Each
// specialisation is instantiated in registry.cpp; a run picks one when it starts.
//
// One step (symplectic Euler, 2.2): contact pass over the half pair list and the near-wall list
// (forces from x^n, v^n, w^n, history updated), a gather pass that sums each particle's contacts
// in ascending partner-id order (bit-identical for any thread count), then
// v^{n+1} = v^n + dt F/m, w^{n+1} = w^n + dt T/I, x^{n+1} = x^n + dt v^{n+1}.
#pragma once
#include <algorithm>
#include <cmath>

#include "contact/law.hpp"
#include "simulation.hpp"

namespace tsubu::detail {

template <class Law, bool MovingWalls>
struct Stepper {
  using History = typename Law::History;
  static constexpr bool kHistory = Law::has_history;
  static constexpr bool kTorque = Law::has_torque;
  static constexpr bool kTangential = Law::tangential::enabled;
  static constexpr bool kRolling = Law::rolling::enabled;

  static void run(Simulation& s, long steps) {
    const double dt = s.dt_;
    for (long k = 0; k < steps; ++k) {
      if (s.needs_rebuild()) s.rebuild(true);
      double worst = 0;
      pair_pass(s, dt, worst);
      wall_pass(s, dt, worst);
      if (!(worst <= s.opt_.max_overlap)) s.report_overlap(dt);
      if (gather(s)) s.report_nonfinite();
      integrate(s, dt);
      if constexpr (MovingWalls) s.move_planes(dt);
      ++s.step_;
      s.time_ += dt;
    }
  }

  static void load(History& h, const double* xi) {
    if constexpr (kHistory) std::copy(xi, xi + 3, h.xi);
    (void)h;
    (void)xi;
  }
  static void store(const History& h, double* xi) {
    if constexpr (kHistory) std::copy(h.xi, h.xi + 3, xi);
    (void)h;
    (void)xi;
  }

  // A contact that opens loses the energy still stored in its tangential spring.
  static void release(const PairParams& p, double* xi, double& dissipated) {
    const double u2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
    if (u2 == 0) return;
    dissipated += 0.5 * p.kt * u2;
    std::fill(xi, xi + 3, 0.0);
  }

  static void pair_pass(Simulation& s, double dt, double& worst_out) {
    const Index n = static_cast<Index>(s.n_);
    const double *x = s.x_.data(), *v = s.v_.data(), *w = s.w_.data();
    const double *r = s.radius_.data(), *m = s.mass_.data(), *inv_i = s.inv_inertia_.data();
    const int* mat = s.material_.data();
    const Index *off = s.pair_offset_.data(), *partner = s.pair_partner_.data();
    double *xi = s.pair_xi_.data(), *force = s.pair_force_.data(), *nxft = s.pair_nxft_.data();
    double *roll = s.pair_roll_.data(), *overlap = s.pair_overlap_.data();
    double* diss = s.dissipated_.data();
    const PairTable& table = s.pairs_;
    double worst = 0;
#pragma omp parallel for schedule(static) num_threads(s.threads()) reduction(max : worst)
    for (Index i = 0; i < n; ++i) {
      const Vec3 xi_pos = vec3(x, i);
      const double ri = r[i];
      for (Index e = off[i]; e < off[i + 1]; ++e) {
        const Index j = partner[e];
        const Vec3 d = xi_pos - vec3(x, j);
        const double rs = ri + r[j];
        const double dist2 = d.squaredNorm();
        if (dist2 >= rs * rs) {  // (1.10): no contact; the history ends with it
          overlap[e] = 0;
          if constexpr (kHistory) release(table(mat[i], mat[j]), xi + 3 * e, diss[i]);
          continue;
        }
        ContactGeometry g;
        const double dist = std::sqrt(dist2);
        g.delta = rs - dist;
        g.n = d / dist;
        worst = std::max(worst, g.delta / std::min(ri, r[j]));
        g.m_eff = m[i] * m[j] / (m[i] + m[j]);
        const Vec3 vrel = vec3(v, i) - vec3(v, j);
        g.vn = vrel.dot(g.n);
        if constexpr (kTorque) {
          g.ci = ri - 0.5 * g.delta;
          g.cj = r[j] - 0.5 * g.delta;
        }
        if constexpr (kTangential)
          g.vt = vrel - g.vn * g.n - (g.ci * vec3(w, i) + g.cj * vec3(w, j)).cross(g.n);
        if constexpr (kRolling) {
          g.w_rel = vec3(w, i) - vec3(w, j);
          g.ri = ri;
          g.rj = r[j];
          g.spin_mobility = ri * inv_i[i] + r[j] * inv_i[j];
        }
        History h;
        load(h, xi + 3 * e);
        ContactResult res;
        Law::evaluate(g, table(mat[i], mat[j]), dt, h, res);
        store(h, xi + 3 * e);
        overlap[e] = g.delta;
        vec3(force, e) = res.force;
        if constexpr (kTangential) vec3(nxft, e) = res.n_cross_ft;
        if constexpr (kRolling) {
          vec3(roll, e) = res.roll;
          res.power -= res.roll.dot(ri * vec3(w, i) - r[j] * vec3(w, j));
        }
        diss[i] += res.power * dt;  // the owner books the pair's dissipation
      }
    }
    worst_out = std::max(worst_out, worst);
  }

  static void wall_pass(Simulation& s, double dt, double& worst_out) {
    if (s.planes_.empty()) return;
    const Index n = static_cast<Index>(s.n_);
    const double *x = s.x_.data(), *v = s.v_.data(), *w = s.w_.data();
    const double *r = s.radius_.data(), *m = s.mass_.data(), *inv_i = s.inv_inertia_.data();
    const int* mat = s.material_.data();
    const Index *off = s.wall_offset_.data(), *wall = s.wall_index_.data();
    double *xi = s.wall_xi_.data(), *force = s.wall_force_.data(), *nxft = s.wall_nxft_.data();
    double *roll = s.wall_roll_.data(), *overlap = s.wall_overlap_.data();
    double* diss = s.dissipated_.data();
    const Plane* planes = s.planes_.data();
    const PairTable& table = s.pairs_;
    double worst = 0;
#pragma omp parallel for schedule(static) num_threads(s.threads()) reduction(max : worst)
    for (Index i = 0; i < n; ++i) {
      for (Index e = off[i]; e < off[i + 1]; ++e) {
        const Plane& P = planes[wall[e]];
        const Vec3 xi_pos = vec3(x, i);
        const double ri = r[i];
        const double delta = ri - P.normal.dot(xi_pos - P.point);  // (3.1), signed: a half-space
        if (delta <= 0) {
          overlap[e] = 0;
          if constexpr (kHistory) release(table(mat[i], P.material), xi + 3 * e, diss[i]);
          continue;
        }
        ContactGeometry g;
        g.n = P.normal;
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
        History h;
        load(h, xi + 3 * e);
        ContactResult res;
        Law::evaluate(g, table(mat[i], P.material), dt, h, res);
        store(h, xi + 3 * e);
        overlap[e] = delta;
        vec3(force, e) = res.force;
        if constexpr (kTangential) vec3(nxft, e) = res.n_cross_ft;
        if constexpr (kRolling) {
          vec3(roll, e) = res.roll;
          res.power -= ri * res.roll.dot(g.w_rel);
        }
        diss[i] += res.power * dt;
      }
    }
    worst_out = std::max(worst_out, worst);
  }

  // Sums each particle's contacts (lower-id partners, higher-id partners, then walls) into f, t.
  // Returns true if some sum is not finite.
  static bool gather(Simulation& s) {
    const Index n = static_cast<Index>(s.n_);
    const double* r = s.radius_.data();
    const Index *off = s.pair_offset_.data(), *roff = s.rev_offset_.data();
    const Index *rent = s.rev_entry_.data(), *woff = s.wall_offset_.data();
    const double *pf = s.pair_force_.data(), *pt = s.pair_nxft_.data(), *pr = s.pair_roll_.data();
    const double* po = s.pair_overlap_.data();
    const double *wf = s.wall_force_.data(), *wt = s.wall_nxft_.data(), *wr = s.wall_roll_.data();
    const double* wo = s.wall_overlap_.data();
    double *f = s.f_.data(), *t = s.t_.data();
    const bool walls = !s.planes_.empty();
    int bad = 0;
#pragma omp parallel for schedule(static) num_threads(s.threads()) reduction(max : bad)
    for (Index k = 0; k < n; ++k) {
      const double rk = r[k];
      Vec3 F = Vec3::Zero(), T = Vec3::Zero();
      for (Index q = roff[k]; q < roff[k + 1]; ++q) {  // k is the partner: reaction
        const Index e = rent[q];
        if (!(po[e] > 0)) continue;
        F -= vec3(pf, e);
        if constexpr (kTangential) T -= (rk - 0.5 * po[e]) * vec3(pt, e);
        if constexpr (kRolling) T -= rk * vec3(pr, e);
      }
      for (Index e = off[k]; e < off[k + 1]; ++e) {
        if (!(po[e] > 0)) continue;
        F += vec3(pf, e);
        if constexpr (kTangential) T -= (rk - 0.5 * po[e]) * vec3(pt, e);
        if constexpr (kRolling) T += rk * vec3(pr, e);
      }
      if (walls) {
        for (Index e = woff[k]; e < woff[k + 1]; ++e) {
          if (!(wo[e] > 0)) continue;
          F += vec3(wf, e);
          if constexpr (kTangential) T -= (rk - 0.5 * wo[e]) * vec3(wt, e);
          if constexpr (kRolling) T += rk * vec3(wr, e);
        }
      }
      vec3(f, k) = F;
      if constexpr (kTorque) vec3(t, k) = T;
      const double sum = F.sum() + T.sum();
      if (!(sum - sum == 0)) bad = 1;  // inf or NaN somewhere (allFinite() is not inlined)
    }
    return bad != 0;
  }

  static void integrate(Simulation& s, double dt) {
    const Index n = static_cast<Index>(s.n_);
    double *x = s.x_.data(), *v = s.v_.data(), *w = s.w_.data();
    const double *f = s.f_.data(), *t = s.t_.data(), *xr = s.x_ref_.data();
    const double *inv_m = s.inv_mass_.data(), *inv_i = s.inv_inertia_.data();
    const double gx = s.opt_.gravity.x(), gy = s.opt_.gravity.y(), gz = s.opt_.gravity.z();
    double md = 0;
#pragma omp parallel for schedule(static) num_threads(s.threads()) reduction(max : md)
    for (Index k = 0; k < n; ++k) {
      const double im = inv_m[k];
      double* vk = v + 3 * k;
      double* xk = x + 3 * k;
      vk[0] += dt * (f[3 * k] * im + gx);
      vk[1] += dt * (f[3 * k + 1] * im + gy);
      vk[2] += dt * (f[3 * k + 2] * im + gz);
      if constexpr (kTorque) {
        const double ii = inv_i[k];
        for (int c = 0; c < 3; ++c) w[3 * k + c] += dt * t[3 * k + c] * ii;
      }
      double d2 = 0;
      for (int c = 0; c < 3; ++c) {
        xk[c] += dt * vk[c];
        const double d = xk[c] - xr[3 * k + c];
        d2 += d * d;
      }
      md = std::max(md, d2);
    }
    s.max_disp2_ = md;
  }
};

}  // namespace tsubu::detail
