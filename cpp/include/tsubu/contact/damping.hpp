// Normal damping laws: the dashpot eta_n of f_n = ... - eta_n v_n. A damping law owns its
// parameters, their mixing rule and the coefficient of one contact.
//
// A damping law splits its coefficient into terms fixed for the life of a near entry (the loop
// computes them once per entry and keeps them: a square root saved per contact and step) and the
// dashpot at the current overlap, from those terms and the normal law's state (lane()).
#pragma once
#include <cmath>

#include "../types.hpp"
#include "normal.hpp"

namespace tsubu {

// The dashpot that gives a linear spring the restitution e for the pair's reduced mass (B.9):
// eta_n = -2 ln e sqrt(m k / (pi^2 + ln^2 e)).
struct RestitutionDamping {
  static constexpr const char* name = "restitution";
  // Its parameter set (contact/parameters.hpp): a material's restitution; a pair's, mixed, and
  // the factor finalise() derives from it.
  struct Properties {
    double restitution = 1;  // normal coefficient of restitution, (0, 1]

    template <class V>
    static constexpr void fields(V&& visit) { visit("restitution", &Properties::restitution); }
  };
  struct Params : Properties {
    // (B.9) as eta_n = damping_factor sqrt(m_eff k_n): a contact then needs one square root.
    double damping_factor = 0;

    template <class M>
    static void mix(const M& a, const M& b, Params& p) { RestitutionDamping::mix(a, b, p); }
    template <class P>
    static void finalise(P& p) { RestitutionDamping::finalise(p); }
  };

  template <class M>
  static void mix(const M& a, const M& b, Params& p) {
    p.restitution = std::sqrt(a.restitution * b.restitution);  // geometric mean
  }
  template <class P>
  static void finalise(P& p) {
    const double le = std::log(p.restitution);
    p.damping_factor = -2.0 * le / std::sqrt(M_PI * M_PI + le * le);
  }
  // eta_n for reduced mass m_eff and normal stiffness k (B.9).
  template <class P>
  static double coefficient(const P& p, double m_eff, double k) {
    return p.damping_factor * std::sqrt(m_eff * k);
  }
  // The dashpot of a linear spring does not depend on the overlap: the entry keeps eta_n itself
  // (of HookeNormal's k_n).
  static constexpr int kEntryTerms = 1;
  template <class P>
  static void entry_terms(const P& p, double m_eff, double* e) { e[0] = coefficient(p, m_eff, p.kn); }
  TSUBU_INLINE static double lane(const double* e, const NormalState&) { return e[0]; }
};

// The dashpot of a Hertzian contact in the "beta" form of Tsuji et al. (1992) as written by EDEM,
// LIGGGHTS and DEM-Engine: eta_n = 2 sqrt(5/6) |beta| sqrt(S_n m*), S_n = 2 E* a,
// beta = ln e / sqrt(ln^2 e + pi^2). eta_n grows as delta^(1/4), and the impact is then
// self-similar: its restitution does not depend on the impact speed (docs/physics.md).
struct HertzDamping {
  static constexpr const char* name = "hertz-beta";
  // Its parameter set (contact/parameters.hpp): nothing a material sets (the restitution is
  // RestitutionDamping's); a pair's factor, derived by finalise() for a Hertzian pair.
  struct Params {
    // 2 sqrt(5/6) |beta| (for a force that may pull), or the value that gives restitution e
    // when F_n is clipped at zero (hertz_repulsive_factor); from finalise().
    double hertz_damping_factor = 0;

    template <class M>
    static void mix(const M& a, const M& b, Params& p) { HertzDamping::mix(a, b, p); }
    template <class P>
    static void finalise(P& p) {
      if (HertzParams::used(p)) HertzDamping::finalise(p);
    }
  };

  template <class M>
  static void mix(const M&, const M&, Params&) {}  // (restitution is mixed by RestitutionDamping)
  template <class P>
  static void finalise(P& p) {
    p.hertz_damping_factor =
        p.normal_floor == 0 ? repulsive_factor(p.restitution) : signed_factor(p.restitution);
  }
  static double signed_factor(double e) {
    const double le = std::log(e);
    return 2.0 * std::sqrt(5.0 / 6.0) * std::abs(le) / std::sqrt(le * le + M_PI * M_PI);
  }
  // The factor f that gives a clipped Hertzian contact restitution e (a table computed on
  // demand: bisection on the impact integrated by restitution()).
  static double repulsive_factor(double e);
  // The restitution of a Hertzian impact with damping eta_n = f sqrt(S_n m*), F_n clipped at
  // zero or not: the dimensionless impact m = 4/3 E* sqrt(R*) = v = 1, integrated with RK4.
  static double restitution(double factor, bool clipped);

  template <class P>
  static double coefficient(const P& p, double m_eff, double stiffness) {
    return p.hertz_damping_factor * std::sqrt(m_eff * stiffness);
  }
  // The entry keeps f sqrt(m*); the lane multiplies by sqrt(S_n).
  static constexpr int kEntryTerms = 1;
  template <class P>
  static void entry_terms(const P& p, double m_eff, double* e) {
    e[0] = p.hertz_damping_factor * std::sqrt(m_eff);
  }
  TSUBU_INLINE static double lane(const double* e, const NormalState& s) {
    return e[0] * std::sqrt(s.stiffness);
  }
};

}  // namespace tsubu
