// One contact law = one evaluator per slot (normal, damping, tangential, rolling, roughness),
// combined at compile time. The loop (engine/) is a template over it and asks it for everything
// law-specific: the lane form, the parameters a lane reads, the history it keeps, the energy a
// contact holds and the time-step bounds. A slot a scene does not use costs nothing.
#pragma once
#include <cmath>
#include <string>
#include <type_traits>

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
  // A sticky normal law's contact survives to a negative overlap (contact/normal.hpp): an entry
  // that does not touch starts to at delta > 0; one that touches keeps touching while
  // delta > -separation.
  static constexpr bool kSticky = Normal::kSticky;
  // The largest separation a touching contact of reduced radius r_eff survives (0 if not sticky).
  static double separation(const PairParams& p, double r_eff) {
    if constexpr (kSticky) return Normal::separation(p, r_eff);
    (void)p, (void)r_eff;
    return 0;
  }
  // The same from an entry's terms (entry_terms()); for the loop.
  TSUBU_INLINE static double entry_separation(const double* e) {
    if constexpr (kSticky) return Normal::entry_separation(e);
    (void)e;
    return 0;
  }
  // What the normal spring of a sticky contact holds at overlap delta, from the packed
  // parameters q and the entry's terms e: lost when the contact breaks (0 if not sticky).
  static double lane_energy(const double* q, const double* e, double delta) {
    if constexpr (kSticky) return Normal::lane_energy(q, e, delta);
    (void)q, (void)e, (void)delta;
    return 0;
  }
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

  // The terms of a contact of reduced mass m_eff and reduced radius r_eff fixed while the pair
  // is in the near list (the loop keeps them per entry): the normal law's, then the damping
  // law's. lane() turns them into the force at an overlap.
  static constexpr int kEntryTerms = Normal::kEntryTerms + Damping::kEntryTerms;
  static constexpr bool kForceReadsEntry =
      std::is_invocable_v<decltype(&Normal::force), const double*, const double*, const NormalState&,
                          double, double, double, double&>;
  static void entry_terms(const PairParams& p, double m_eff, double r_eff, double* e) {
    Normal::entry_terms(p, r_eff, e);
    Damping::entry_terms(p, m_eff, e + Normal::kEntryTerms);
  }

  // The normal and tangential laws of one contact in lane form (plain doubles, no branches): a
  // block of contacts runs it in a loop the compiler vectorises. Sets F (on i), n x F_t (which
  // holds last step's on entry: zero for a new contact) and the dissipated power; updates the
  // tangential history xi (and aux, its fourth value where the law keeps one). q: the packed
  // parameters; e: the entry's terms. Returns the signed f_n.
  TSUBU_INLINE static double lane(L3 n, L3 vt, double delta, double vn, const double* e,
                                  const double* q, double dt, L3& xi, double& aux, L3& force,
                                  L3& n_cross_ft, double& power) {
    bool far = false;
    return lane_as<false>(n, vt, delta, vn, e, q, dt, xi, aux, force, n_cross_ft, power, far);
  }
  // Whether lane_as<true> can skip a rare costly step of the tangential law (and say where).
  static constexpr bool kDeferred = Tangential::kDeferred;
  // lane(); kDeferred laws with kSeriesOnly: `far` set where the tangential law skipped a step
  // (Tangential::lane_as), whose lane must be evaluated again by lane().
  template <bool kSeriesOnly>
  TSUBU_INLINE static double lane_as(L3 n, L3 vt, double delta, double vn, const double* e,
                                     const double* q, double dt, L3& xi, double& aux, L3& force,
                                     L3& n_cross_ft, double& power, bool& far) {
    const NormalState s = Normal::state(q, e, delta);
    const double eta_n = Damping::lane(e + Normal::kEntryTerms, s);
    double fn;
    if constexpr (kForceReadsEntry)  // a law whose force reads the entry's terms (DMT's F_c)
      fn = Normal::force(q, e, s, delta, eta_n, vn, power);
    else
      fn = Normal::force(q, s, delta, eta_n, vn, power);
    force = fn * n;
    if constexpr (Tangential::enabled) {
      const double* t = q + kNormalParams;  // the tangential law's packed parameters
      Tangential::follow(t, s, dt, xi, aux, power);
      // last step's F_t, turned into this tangent plane, on this step's v_t: (n' x F) x n . v_t
      const double prev_work = dot(n_cross_ft, cross(n, vt));
      L3 ft;
      if constexpr (kSeriesOnly && kDeferred)
        ft = Tangential::template lane_as<true>(n, vt, Tangential::stiffness(t, s), Tangential::compliance(t, s),
                                                Tangential::damping(t, eta_n), Tangential::cap(t, fn), dt,
                                                prev_work, xi, power, far);
      else
        ft = Tangential::lane(n, vt, Tangential::stiffness(t, s), Tangential::compliance(t, s),
                              Tangential::damping(t, eta_n), Tangential::cap(t, fn), dt, prev_work, xi, power);
      force = force + ft;
      n_cross_ft = cross(n, ft);
    } else {
      (void)vt;
      (void)xi;
      (void)aux;
      (void)n_cross_ft;
    }
    (void)far;
    return fn;
  }

  // One contact measured in g (the Eigen form: single contacts and the C++ tests).
  TSUBU_INLINE static void evaluate(const ContactGeometry& g, const PairParams& p, double dt,
                                    History& h, ContactResult& out) {
    double q[kLaneParams > 0 ? kLaneParams : 1];
    pack(p, q);
    L3 xi{0, 0, 0}, force, nxft = lanes(g.prev_n_cross_ft);
    double aux = 0;
    if constexpr (has_history) xi = {h.xi[0], h.xi[1], h.xi[2]};
    if constexpr (history_width > 3) aux = h.xi[3];
    out.fn = lane(lanes(g.n), lanes(g.vt), g.delta, g.vn, g.entry, q, dt, xi, aux, force, nxft,
                  out.power);
    if constexpr (has_history) {
      h.xi[0] = xi.x;
      h.xi[1] = xi.y;
      h.xi[2] = xi.z;
    } else {
      (void)h;
    }
    if constexpr (history_width > 3) h.xi[3] = aux;
    out.force = vec(force);
    out.n_cross_ft = vec(nxft);
    if constexpr (Rolling::enabled) out.roll = Rolling::evaluate(g, p, std::abs(out.fn), dt);
  }

  // ---- energy ------------------------------------------------------------------------------
  // What the normal spring of a contact with overlap delta and reduced radius r_eff holds.
  static double normal_energy(const PairParams& p, double delta, double r_eff) {
    return Normal::elastic_energy(p, delta, r_eff);
  }
  // The normal spring's force at overlap delta (no dashpot).
  static double elastic_force(const PairParams& p, double delta, double r_eff) {
    return Normal::elastic_force(p, delta, r_eff);
  }
  // What the tangential spring with history xi (history_width values) holds; 0 without one.
  static double tangential_energy(const PairParams& p, const double* xi) {
    return with_tangential(p, [xi](const double* q) { return Tangential::elastic_energy(q, xi); });
  }
  // The tangential spring's stiffness for a stored history (the energy audit's power); 0
  // without one.
  static double tangential_stiffness(const PairParams& p, const double* xi) {
    return with_tangential(p, [xi](const double* q) { return Tangential::history_stiffness(q, xi); });
  }
  // f(the tangential law's packed parameters of the pair), or 0 for a law without a spring.
  template <class F>
  static double with_tangential(const PairParams& p, F&& f) {
    if constexpr (has_history) {
      double q[Tangential::kLaneParams];
      Tangential::pack(p, q);
      return f(static_cast<const double*>(q));
    }
    (void)p, (void)f;
    return 0;
  }
  // Whether a pair's parameters give it a tangential force under this law.
  static bool friction_used(const PairParams& p) {
    if constexpr (Tangential::enabled) return Tangential::used(p);
    (void)p;
    return false;
  }

  // ---- time-step bounds --------------------------------------------------------------------
  // The normal stiffness of a contact at scale s (a linear spring's; a Hertzian contact's at the
  // peak of an impact at the scale's speed) and its dashpot there.
  static double stiffness(const PairParams& p, const ContactScale& s) { return Normal::stiffest(p, s).stiffness; }
  static double dashpot(const PairParams& p, const ContactScale& s) {
    return Damping::coefficient(p, s.mass, stiffness(p, s));
  }
  // The normal oscillation's angular frequency (B.3) at scale s.
  static double oscillation_rate(const PairParams& p, const ContactScale& s) {
    const double m = s.mass, eta = dashpot(p, s);
    return std::sqrt(stiffness(p, s) / m - eta * eta / (4 * m * m));
  }
  // How long an impact at scale s lasts, as the normal law says (it may use the damped
  // oscillation's rate, computed on demand).
  static double contact_duration(const PairParams& p, const ContactScale& s) {
    return Normal::contact_duration(p, s, [&] { return oscillation_rate(p, s); });
  }
  // The largest stable dt of symplectic Euler for a contact at scale s (2.31), with the
  // tangential spring where the law has one (for a Hertzian contact: at the stiffest overlap of
  // an impact at the scale's speed).
  static double critical_time_step(const PairParams& p, const ContactScale& s) {
    const double m = s.mass, eta_n = dashpot(p, s);
    double bound = euler_bound(m, stiffness(p, s), eta_n);
    // A sphere that can roll moves its contact point under a tangential force as a mass m/3.5
    // would (1/m + c^2/I = 3.5/m).
    if constexpr (Tangential::enabled)
      if (friction_used(p)) {
        double q[Tangential::kLaneParams];
        Tangential::pack(p, q);
        const double kt = Tangential::stiffness(q, Normal::stiffest(p, s));
        bound = std::min(bound, euler_bound(m / 3.5, kt, p.tangential_damping * eta_n));
      }
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
