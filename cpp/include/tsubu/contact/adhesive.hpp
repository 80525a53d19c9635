// Adhesive normal laws on Hertz's elastic sphere: JKR (Johnson, Kendall & Roberts 1971) and DMT
// (Derjaguin, Muller & Toporov 1975), with the work of adhesion w [J/m^2] of the pair. Both are
// Hertzian laws (E*, G*, the Hertzian dashpot and Mindlin's spring, docs/physics.md) and give
// Hertz's force bit for bit at w = 0.
//
// JKR: the contact radius a follows the overlap as delta = a^2/R* - sqrt(2 pi w a / E*) (Johnson
// 1985, eq. 5.141) and F = 4 E* a^3 / (3 R*) - sqrt(8 pi w E* a^3). A contact is made at
// delta = 0 (snap-in) and holds, on the stable branch, down to the displacement-controlled limit
// dDelta/da = 0: a_c = (pi w R*^2 / (8 E*))^(1/3), delta_c = -3 a_c^2 / R*
// = -(3/4) (pi^2 w^2 R* / E*^2)^(1/3), where F = -(5/9) F_c. Under a pull (force control) it
// leaves at F_c = (3/2) pi w R* (a = (9 pi w R*^2 / (8 E*))^(1/3), delta = -a^2 / (3 R*)).
//
// DMT: Hertz's force less the constant pull 2 pi w R* while in contact, made and broken at
// delta = 0: F_c = 2 pi w R*.
#pragma once
#include <algorithm>
#include <cmath>

#include "normal.hpp"

namespace tsubu {

// The work of adhesion w of a material against itself (2 gamma, gamma its surface energy) and
// its mixing rule: the geometric mean w_ij = sqrt(w_i w_j). (Dupre: w_ij = gamma_i + gamma_j -
// gamma_ij; with Berthelot's gamma_ij = gamma_i + gamma_j - 2 sqrt(gamma_i gamma_j) for
// dispersive surfaces it is 2 sqrt(gamma_i gamma_j) = sqrt(w_i w_j).) A pair with one
// non-adhesive surface has w = 0.
//
// The parameter set (contact/parameters.hpp) of both laws: a material's w and a pair's.
struct AdhesionParams {
  double work_of_adhesion = 0;  // w, J/m^2; 0: no adhesion

  template <class V>
  static constexpr void fields(V&& visit) { visit("work_of_adhesion", &AdhesionParams::work_of_adhesion); }

  template <class M>
  static void mix(const M& a, const M& b, AdhesionParams& p) {
    p.work_of_adhesion = std::sqrt(a.work_of_adhesion * b.work_of_adhesion);
  }
  static bool used(const AdhesionParams& p) { return p.work_of_adhesion > 0; }
};

namespace jkr {
// a_c = (pi w R^2 / (8 E))^(1/3): the contact radius where a JKR contact breaks under
// displacement control; 0 at w = 0.
inline double critical_radius(double E, double w, double R) {
  return w > 0 ? std::cbrt(M_PI * w * R * R / (8.0 * E)) : 0.0;
}
// The root y >= 1 of y^4 - 4 y = d (d >= -3): a = a_c y^2 solves delta = a^2/R - sqrt(2 pi w a/E)
// for d = delta R / a_c^2 (then delta = (a_c^2/R)(x^2 - 4 sqrt(x)), x = a / a_c). Ferrari:
// (y^2 + m)^2 = 2m (y + 1/m)^2 where m > 0 is the real root of m^3 + d m - 2 = 0 (Cardano, in
// a form without cancellation for either sign of d), and y is the larger root of
// y^2 - sqrt(2m) y + m - sqrt(2m)/m = 0. Exact in closed form: no iteration, no branch.
TSUBU_INLINE double unit_root(double d) {
  d = std::max(d, -3.0);
  const double s = std::sqrt(std::max(1.0 + d * d * d / 27.0, 0.0));
  const double u = std::cbrt(1.0 + s), v = -d / (3.0 * u);  // u v = -d/3, u^3 + v^3 = 2
  const double m = d >= 0 ? 2.0 / (u * u + d / 3.0 + v * v) : u + v;
  const double r = std::sqrt(2.0 * m);
  return 0.5 * (r + std::sqrt(std::max(4.0 * r / m - 2.0 * m, 0.0)));
}
// The contact radius at overlap delta on the stable branch (delta below delta_c: a_c).
inline double contact_radius(double E, double w, double R, double delta) {
  const double ac = critical_radius(E, w, R);
  if (!(ac > 0)) return std::sqrt(R * std::max(delta, 0.0));
  const double y = unit_root(delta * R / (ac * ac));
  return ac * y * y;
}
// F(a) = 4 E a^3 / (3 R) - sqrt(8 pi w E a^3).
inline double force(double E, double w, double R, double a) {
  return 4.0 * E * a * a * a / (3.0 * R) - std::sqrt(8.0 * M_PI * w * E * a * a * a);
}
// The work of F along the branch from a0 (delta = 0) to a: G(a) - G(a0), with
// G(a) = 8 E a^5 / (15 R^2) - (2/3) sqrt(8 pi w E) a^(7/2) / R + pi w a^2 (the integral of
// F(a) dDelta/da), a0 = (2 pi w R^2 / E)^(1/3).
inline double energy(double E, double w, double R, double a) {
  auto G = [&](double x) {
    return 8.0 * E * std::pow(x, 5) / (15.0 * R * R) -
           2.0 / 3.0 * std::sqrt(8.0 * M_PI * w * E) * std::pow(x, 3.5) / R + M_PI * w * x * x;
  };
  return G(a) - G(std::cbrt(2.0 * M_PI * w * R * R / E));
}
}  // namespace jkr

// JKR on Hertz's sphere. A sticky law: its contacts hold to delta_c < 0.
struct JkrNormal {
  static constexpr const char* name = "jkr";
  static constexpr bool kSticky = true;

  // Lanes read E*, the floor (as Hertz's) and w; an entry keeps sqrt(R*) (Hertz's a at w = 0),
  // a_c, R*/a_c^2, the separation -delta_c = 3 a_c^2/R* (0, 0 and 0 at w = 0) and R*.
  static constexpr int kLaneParams = 3, kEntryTerms = 5;
  template <class P>
  static void pack(const P& p, double* q) {
    q[0] = p.effective_modulus;
    q[1] = p.normal_floor;
    q[2] = p.work_of_adhesion;
  }
  template <class P>
  static void entry_terms(const P& p, double r_eff, double* e) {
    const double ac = jkr::critical_radius(p.effective_modulus, p.work_of_adhesion, r_eff);
    e[0] = std::sqrt(r_eff);
    e[1] = ac;
    e[2] = ac > 0 ? r_eff / (ac * ac) : 0.0;
    e[3] = ac > 0 ? 3.0 * ac * ac / r_eff : 0.0;
    e[4] = r_eff;
  }
  // The largest separation a touching contact survives: -delta_c = 3 a_c^2 / R*.
  template <class P>
  static double separation(const P& p, double r_eff) {
    const double ac = jkr::critical_radius(p.effective_modulus, p.work_of_adhesion, r_eff);
    return 3.0 * ac * ac / r_eff;
  }
  TSUBU_INLINE static double entry_separation(const double* e) { return e[3]; }

  // a from the closed form (Hertz's sqrt(R*) sqrt(delta) at w = 0); S_n = 2 E* a, the Hertzian
  // stiffness at the JKR contact radius, for the dashpot and Mindlin's spring.
  TSUBU_INLINE static NormalState state(const double* q, const double* e, double delta) {
    const double hertz = e[0] * std::sqrt(std::max(delta, 0.0));
    const double y = jkr::unit_root(delta * e[2]);
    const double a = e[1] > 0 ? e[1] * y * y : hertz;
    return {2.0 * q[0] * a, a};
  }
  // F_n = 4 E* a^3/(3 R*) - sqrt(8 pi w E* a^3) = (2/3) S_n (delta - sqrt(2 pi w a / E*) / 2)
  // (with a^2/R* = delta + sqrt(2 pi w a / E*)), less the Hertzian dashpot: Hertz's expression
  // at w = 0. Power lost as Hertz's.
  TSUBU_INLINE static double force(const double* q, const NormalState& s, double delta, double eta_n,
                                   double vn, double& power) {
    const double neck = std::sqrt(2.0 * M_PI * q[2] * s.size / q[0]);
    const double elastic = (2.0 / 3.0) * s.stiffness * (delta - 0.5 * neck);
    const double fn = std::max(mul_add(-eta_n, vn, elastic), q[1]);
    power = (elastic - fn) * vn;
    return fn;
  }
  // The work of F_n along the branch from snap-in (delta = 0) to delta (at most delta_c below
  // 0): what the contact stores, and what is lost when it breaks. Hertz's at w = 0.
  template <class P>
  static double elastic_energy(const P& p, double delta, double r_eff) {
    if (!(p.work_of_adhesion > 0)) return HertzNormal::elastic_energy(p, delta, r_eff);
    if (delta == 0) return 0;
    const double E = p.effective_modulus, w = p.work_of_adhesion;
    return jkr::energy(E, w, r_eff, jkr::contact_radius(E, w, r_eff, delta));
  }
  template <class P>
  static double elastic_force(const P& p, double delta, double r_eff) {
    if (!(p.work_of_adhesion > 0)) return HertzNormal::elastic_force(p, delta, r_eff);
    const double E = p.effective_modulus, w = p.work_of_adhesion;
    return jkr::force(E, w, r_eff, jkr::contact_radius(E, w, r_eff, delta));
  }
  // The same from a lane's parameters and an entry's terms.
  static double lane_energy(const double* q, const double* e, double delta) {
    if (delta == 0) return 0;  // (an entry that does not touch stores 0)
    if (!(q[2] > 0)) return delta > 0 ? 8.0 / 15.0 * q[0] * e[0] * delta * delta * std::sqrt(delta) : 0.0;
    return jkr::energy(q[0], q[2], e[4], jkr::contact_radius(q[0], q[2], e[4], delta));
  }
  // The time-step bound and the contact duration: Hertz's at the peak of an impact (the
  // adhesive neck changes the stiffness at that overlap little).
  template <class P>
  static NormalState stiffest(const P& p, const ContactScale& s) { return HertzNormal::stiffest(p, s); }
  template <class P, class Rate>
  static double contact_duration(const P& p, const ContactScale& s, Rate&& rate) {
    return HertzNormal::contact_duration(p, s, rate);
  }
};

// DMT on Hertz's sphere: F = (4/3) E* sqrt(R*) delta^(3/2) - 2 pi w R* while delta > 0.
struct DmtNormal {
  static constexpr const char* name = "dmt";
  static constexpr bool kSticky = false;  // made and broken at delta = 0

  // Lanes read E* and the floor (Hertz's); an entry keeps sqrt(R*) and F_c = 2 pi w R*.
  static constexpr int kLaneParams = 2, kEntryTerms = 2;
  template <class P>
  static void pack(const P& p, double* q) { HertzNormal::pack(p, q); }
  template <class P>
  static void entry_terms(const P& p, double r_eff, double* e) {
    e[0] = std::sqrt(r_eff);
    e[1] = 2.0 * M_PI * p.work_of_adhesion * r_eff;
  }
  TSUBU_INLINE static NormalState state(const double* q, const double* e, double delta) {
    return HertzNormal::state(q, e, delta);
  }
  // Hertz's force less F_c (Hertz's expression at w = 0: x - 0 is x).
  TSUBU_INLINE static double force(const double* q, const double* e, const NormalState& s,
                                   double delta, double eta_n, double vn, double& power) {
    const double elastic = (2.0 / 3.0) * s.stiffness * delta - e[1];
    const double fn = std::max(mul_add(-eta_n, vn, elastic), q[1]);
    power = (elastic - fn) * vn;
    return fn;
  }
  template <class P>
  static double elastic_energy(const P& p, double delta, double r_eff) {
    if (delta <= 0) return 0;
    return HertzNormal::elastic_energy(p, delta, r_eff) - 2.0 * M_PI * p.work_of_adhesion * r_eff * delta;
  }
  template <class P>
  static double elastic_force(const P& p, double delta, double r_eff) {
    if (delta <= 0) return 0;
    return HertzNormal::elastic_force(p, delta, r_eff) - 2.0 * M_PI * p.work_of_adhesion * r_eff;
  }
  template <class P>
  static NormalState stiffest(const P& p, const ContactScale& s) { return HertzNormal::stiffest(p, s); }
  template <class P, class Rate>
  static double contact_duration(const P& p, const ContactScale& s, Rate&& rate) {
    return HertzNormal::contact_duration(p, s, rate);
  }
};

}  // namespace tsubu
