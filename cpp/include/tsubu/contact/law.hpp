// One contact law = one evaluator per slot (normal, damping, tangential, rolling, roughness),
// combined at compile time. The loop (engine/) is a template over it and asks it for everything
// law-specific: the lane form, the parameters a lane reads, the history it keeps, the energy a
// contact holds and the time-step bounds. A slot a scene does not use costs nothing.
#pragma once
#include <cmath>
#include <string>

#include "../material.hpp"
#include "geometry.hpp"

namespace tsubu {

template <class Normal, class Damping, class Tangential, class Rolling, class Roughness>
struct ContactLaw {
  using normal = Normal;
  using damping = Damping;
  using tangential = Tangential;
  using rolling = Rolling;
  using roughness = Roughness;
  using History = typename Tangential::History;
  static constexpr bool has_history = Tangential::enabled;
  static constexpr int history_width = Tangential::history_width;
  // A tilted normal gives torque even without friction.
  static constexpr bool has_torque = Tangential::enabled || Rolling::enabled || Roughness::enabled;

  static std::string name() {
    std::string s = std::string(Normal::name) + "+" + Tangential::name;
    if (Rolling::enabled) s += std::string("+") + Rolling::name;
    if (Roughness::enabled) s += std::string("+") + Roughness::name;
    return s;
  }

  // The pair parameters one lane reads, packed as doubles: the normal law's, then the
  // tangential law's (a block of contacts keeps one column of each).
  static constexpr int kNormalParams = Normal::kLaneParams;
  static constexpr int kLaneParams = Normal::kLaneParams + Tangential::kLaneParams;
  static void pack(const PairParams& p, double* q) {
    Normal::pack(p, q);
    Tangential::pack(p, q + kNormalParams);
  }

  // The damping law's term for a contact of reduced mass m_eff, fixed while the pair is in the
  // near list (the loop keeps it per entry); lane() turns it into the dashpot at an overlap.
  static double damping_term(const PairParams& p, double m_eff) {
    return Damping::entry_term(p, m_eff, Normal::stiffness(p));
  }

  // The normal and tangential laws of one contact in lane form (plain doubles, no branches): a
  // block of contacts runs it in a loop the compiler vectorises. Sets F (on i), n x F_t and the
  // dissipated power; updates the tangential displacement xi. q: the packed parameters;
  // damping: the entry's damping_term.
  TSUBU_INLINE static void lane(L3 n, L3 vt, double delta, double vn, double damping,
                                const double* q, double dt, L3& xi, L3& force, L3& n_cross_ft,
                                double& power) {
    const double eta_n = Damping::lane(damping, q, delta);
    const double fn = Normal::lane(q, delta, eta_n, vn);
    force = fn * n;
    power = eta_n * vn * vn;
    if constexpr (Tangential::enabled) {
      const double* t = q + kNormalParams;  // kt, mu, eta_t / eta_n
      const L3 ft = Tangential::lane(n, vt, t[0], t[2] * eta_n, t[1] * std::abs(fn), dt, xi, power);
      force = force + ft;
      n_cross_ft = cross(n, ft);
    } else {
      (void)vt;
      (void)xi;
      (void)n_cross_ft;
    }
  }

  // One contact measured in g (the Eigen form: single contacts and the C++ tests).
  TSUBU_INLINE static void evaluate(const ContactGeometry& g, const PairParams& p, double dt,
                                    History& h, ContactResult& out) {
    double q[kLaneParams > 0 ? kLaneParams : 1];
    pack(p, q);
    L3 xi{0, 0, 0}, force, nxft{0, 0, 0};
    if constexpr (has_history) xi = {h.xi[0], h.xi[1], h.xi[2]};
    lane(lanes(g.n), lanes(g.vt), g.delta, g.vn, g.damping, q, dt, xi, force, nxft, out.power);
    if constexpr (has_history) {
      h.xi[0] = xi.x;
      h.xi[1] = xi.y;
      h.xi[2] = xi.z;
    } else {
      (void)h;
    }
    out.fn = Normal::lane(q, g.delta, Damping::lane(g.damping, q, g.delta), g.vn);
    out.force = vec(force);
    out.n_cross_ft = vec(nxft);
    if constexpr (Rolling::enabled) out.roll = Rolling::evaluate(g, p, std::abs(out.fn), dt);
  }

  // ---- energy ------------------------------------------------------------------------------
  // What the normal spring of a contact with overlap delta holds.
  static double normal_energy(const PairParams& p, double delta) {
    return Normal::elastic_energy(p, delta);
  }
  // The normal spring's force at overlap delta (no dashpot).
  static double elastic_force(const PairParams& p, double delta) {
    double q[kNormalParams];
    Normal::pack(p, q);
    return Normal::lane(q, delta, 0.0, 0.0);
  }
  // What the tangential spring with history xi (history_width values) holds; 0 without one.
  static double tangential_energy(const PairParams& p, const double* xi) {
    if constexpr (has_history) {
      double q[Tangential::kLaneParams];
      Tangential::pack(p, q);
      return Tangential::elastic_energy(q, xi);
    }
    (void)p, (void)xi;
    return 0;
  }

  // ---- time-step bounds --------------------------------------------------------------------
  // The normal oscillation's angular frequency (B.3) for reduced mass m.
  static double oscillation_rate(const PairParams& p, double m) {
    return Normal::oscillation_rate(p, m, Damping::coefficient(p, m, Normal::stiffness(p)));
  }
  // How long an impact of reduced mass m lasts (B.5).
  static double contact_duration(const PairParams& p, double m) {
    return M_PI / oscillation_rate(p, m);
  }
  // The largest stable dt of symplectic Euler for a contact of reduced mass m (2.31), with the
  // tangential spring where the law has one.
  static double critical_time_step(const PairParams& p, double m) {
    const double eta_n = Damping::coefficient(p, m, Normal::stiffness(p));
    double bound = euler_bound(m, Normal::stiffness(p), eta_n);
    // A sphere that can roll moves its contact point under a tangential force as a mass m/3.5
    // would (1/m + c^2/I = 3.5/m).
    if constexpr (Tangential::enabled)
      if (FrictionParams::used(p))
        bound = std::min(bound, euler_bound(m / 3.5, p.kt, p.tangential_damping * eta_n));
    return bound;
  }
  // Symplectic Euler of m x'' = -k x - eta x' (dashpot on the old velocity, as the loop does) is
  // stable iff k dt^2/m + 2 eta dt/m < 4, i.e. dt < 4m / (eta + sqrt(eta^2 + 4km)): the spring
  // and dashpot conditions of (2.31), 2 sqrt(m/k) and 2m/eta, analysed together (it equals the
  // first for eta = 0 and is below both otherwise: 0.81 x 2 sqrt(m/k) at e = 0.5).
  static double euler_bound(double m, double k, double eta) {
    return 4.0 * m / (eta + std::sqrt(eta * eta + 4.0 * k * m));
  }
};

}  // namespace tsubu
