// Normal damping laws: the dashpot eta_n of f_n = ... - eta_n v_n. A damping law owns its
// parameters, their mixing rule and the coefficient of one contact.
#pragma once
#include <cmath>

#include "../types.hpp"

namespace tsubu {

// The dashpot that gives a linear spring the restitution e for the pair's reduced mass (B.9):
// eta_n = -2 ln e sqrt(m k / (pi^2 + ln^2 e)).
struct RestitutionDamping {
  static constexpr const char* name = "restitution";
  struct Properties {
    double restitution = 1;  // normal coefficient of restitution, (0, 1]
  };
  struct Params : Properties {
    // (B.9) as eta_n = damping_factor sqrt(m_eff k_n): a contact then needs one square root.
    double damping_factor = 0;
  };

  template <class M>
  static void mix(const M& a, const M& b, Params& p) {
    p.restitution = std::sqrt(a.restitution * b.restitution);  // geometric mean
  }
  static void finalise(Params& p) {
    const double le = std::log(p.restitution);
    p.damping_factor = -2.0 * le / std::sqrt(M_PI * M_PI + le * le);
  }
  // eta_n for reduced mass m_eff and normal stiffness k (B.9).
  static double coefficient(const Params& p, double m_eff, double k) {
    return p.damping_factor * std::sqrt(m_eff * k);
  }
  // A damping law splits its coefficient into a term fixed for the life of a near entry (the
  // loop computes it once per entry and keeps it: a square root saved per contact and step) and
  // the dashpot at overlap delta, from that term and the normal law's lane parameters qn.
  // Here the dashpot does not depend on the overlap: the term is eta_n itself.
  static double entry_term(const Params& p, double m_eff, double k) { return coefficient(p, m_eff, k); }
  TSUBU_INLINE static double lane(double term, const double* /*qn*/, double /*delta*/) { return term; }
};

}  // namespace tsubu
