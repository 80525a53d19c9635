// Normal elastic laws. A normal law owns its parameters and their mixing rule, its force in lane
// form, its elastic energy and the stiffness the time-step bounds use. (The adhesive laws, JKR and
// DMT, are in adhesive.hpp.)
//
// A law whose contact, once made, survives to a negative overlap (an adhesive neck, JKR) says so
// with kSticky = true and gives the largest separation a touching contact survives
// (separation(), and entry_separation() from the entry's terms), and the energy its normal
// spring holds from the lane's parameters (lane_energy(), booked as dissipated when the contact
// breaks). A non-sticky law (kSticky = false) touches exactly while delta > 0, and the loop
// compiles to the same instructions as before the hook existed.
//
// In a lane a normal law first measures its state at the overlap (state(): the tangent stiffness
// S_n = dF/d delta the damping and time-step laws read, and the contact size a tangential law may
// scale with), then gives the force (force()). Per-contact terms that do not change while a pair
// is in the near list (e.g. sqrt(R*)) are computed once per entry (kEntryTerms, entry_terms()).
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry.hpp"

namespace tsubu {

// What a normal law tells the other laws of a contact at its current overlap.
struct NormalState {
  double stiffness;  // S_n = dF_n/d delta, N/m
  double size;       // the contact's size: a = sqrt(R* delta) for Hertz (m), 1 for a linear spring
};

// The scales a contact's time-step bounds depend on: reduced mass, reduced radius, impact speed.
struct ContactScale {
  double mass;    // m*, kg
  double radius;  // R*, m
  double speed;   // characteristic normal impact speed, m/s
};

// Linear spring f = k_n delta (1.6).
struct HookeNormal {
  static constexpr const char* name = "hooke";
  static constexpr bool kSticky = false;  // touches while delta > 0
  // Its parameter set (contact/parameters.hpp): a material's and a pair's k_n.
  struct Params {
    double kn = 0;  // N/m

    template <class V>
    static constexpr void fields(V&& visit) { visit("kn", &Params::kn); }
    // Two half-springs in series: the harmonic mean, so that equal materials keep their value.
    template <class M>
    static void mix(const M& a, const M& b, Params& p) {
      p.kn = 2.0 * a.kn * b.kn / (a.kn + b.kn);
    }
  };

  // The parameter a lane reads: k_n. No per-entry term.
  static constexpr int kLaneParams = 1, kEntryTerms = 0;
  static void pack(const Params& p, double* q) { q[0] = p.kn; }
  static void entry_terms(const Params&, double /*r_eff*/, double*) {}
  TSUBU_INLINE static NormalState state(const double* q, const double* /*e*/, double /*delta*/) {
    return {q[0], 1.0};
  }
  // f_n = k_n delta - eta_n v_n along n (1.6); not clipped at zero, as (B.9) assumes.
  TSUBU_INLINE static double force(const double* q, const NormalState&, double delta, double eta_n,
                                   double vn, double& power) {
    power = eta_n * vn * vn;
    return mul_add(q[0], delta, -(eta_n * vn));
  }
  // 1/2 k_n delta^2: what the spring holds.
  static double elastic_energy(const Params& p, double delta, double /*r_eff*/) {
    return 0.5 * p.kn * delta * delta;
  }
  static double elastic_force(const Params& p, double delta, double /*r_eff*/) { return p.kn * delta; }
  // The state of the spring (the same at every overlap), for the stability bound and the
  // contact duration.
  static NormalState stiffest(const Params& p, const ContactScale&) { return {p.kn, 1.0}; }
  // How long an impact lasts: half a period of the damped oscillation, pi / alpha (B.5).
  template <class Rate>
  static double contact_duration(const Params&, const ContactScale&, Rate&& damped_rate) {
    return M_PI / damped_rate();
  }
};

// Hertz's elastic sphere: F_n = (4/3) E* sqrt(R*) delta^(3/2) (Johnson 1985, eq. 4.22), with the
// per-pair E* of two materials (Johnson eq. 4.23). Its tangent stiffness S_n = 2 E* a,
// a = sqrt(R* delta), is what the damping and the Mindlin spring scale with.
//
// Its parameter set (contact/parameters.hpp): a material's E and nu (HertzMaterial), a pair's
// E* and G* (HertzParams).
struct HertzMaterial {
  double youngs_modulus = 0;   // E, Pa; 0: a linear (kn, kt) material
  double poisson_ratio = 0.3;  // nu, in (-1, 0.5]

  template <class V>
  static constexpr void fields(V&& visit) {
    visit("youngs_modulus", &HertzMaterial::youngs_modulus);
    visit("poisson_ratio", &HertzMaterial::poisson_ratio);
  }
  static bool used(const HertzMaterial& m) { return m.youngs_modulus > 0; }
};

struct HertzParams {
  double effective_modulus = 0;        // E*, Pa; 0: the pair is not Hertzian
  double effective_shear_modulus = 0;  // G*, Pa (Mindlin's k_t = 8 G* a)
  // +0 clips F_n at zero (a contact never pulls); -inf lets the dashpot pull at the end of an
  // impact, as the beta form of the damping assumes (docs/physics.md).
  double normal_floor = -std::numeric_limits<double>::infinity();

  // 1/E* = (1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j; 1/G* = (2 - nu_i)/G_i + (2 - nu_j)/G_j with
  // G = E / (2 (1 + nu)) (Johnson 1985; Di Renzo & Di Maio 2004).
  template <class M>
  static void mix(const M& a, const M& b, HertzParams& p) {
    if (!(a.youngs_modulus > 0 && b.youngs_modulus > 0)) {
      p.effective_modulus = p.effective_shear_modulus = 0;
      return;
    }
    auto shear = [](const M& m) { return m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio)); };
    p.effective_modulus = 1.0 / ((1.0 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus +
                                 (1.0 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus);
    p.effective_shear_modulus =
        1.0 / ((2.0 - a.poisson_ratio) / shear(a) + (2.0 - b.poisson_ratio) / shear(b));
  }
  static bool used(const HertzParams& p) { return p.effective_modulus > 0; }
  template <class V>
  static constexpr void fields(V&& visit) {
    visit("effective_modulus", &HertzParams::effective_modulus);
    visit("effective_shear_modulus", &HertzParams::effective_shear_modulus);
  }
};

struct HertzNormal {
  static constexpr const char* name = "hertz";
  static constexpr bool kSticky = false;  // touches while delta > 0
  using Params = HertzParams;

  // Lanes read E* and the floor; an entry keeps sqrt(R*) (its radii do not change).
  static constexpr int kLaneParams = 2, kEntryTerms = 1;
  static void pack(const Params& p, double* q) {
    q[0] = p.effective_modulus;
    q[1] = p.normal_floor;
  }
  static void entry_terms(const Params&, double r_eff, double* e) { e[0] = std::sqrt(r_eff); }
  // a = sqrt(R*) sqrt(delta); S_n = 2 E* a. (A lane whose contact has just opened has delta < 0:
  // it is measured at 0, so that it stays finite.)
  TSUBU_INLINE static NormalState state(const double* q, const double* e, double delta) {
    const double a = e[0] * std::sqrt(std::max(delta, 0.0));
    return {2.0 * q[0] * a, a};
  }
  // F_n = (4/3) E* a delta - eta_n v_n = (2/3) S_n delta - eta_n v_n, at least the floor. The
  // power lost is (F_elastic - F_n) v_n: eta_n v_n^2 unclipped, F_elastic v_n where clipped.
  TSUBU_INLINE static double force(const double* q, const NormalState& s, double delta, double eta_n,
                                   double vn, double& power) {
    const double elastic = (2.0 / 3.0) * s.stiffness * delta;
    const double fn = std::max(mul_add(-eta_n, vn, elastic), q[1]);
    power = (elastic - fn) * vn;
    return fn;
  }
  // (8/15) E* sqrt(R*) delta^(5/2): the work of F_n from 0 to delta.
  static double elastic_energy(const Params& p, double delta, double r_eff) {
    if (delta <= 0) return 0;
    return 8.0 / 15.0 * p.effective_modulus * std::sqrt(r_eff) * delta * delta * std::sqrt(delta);
  }
  static double elastic_force(const Params& p, double delta, double r_eff) {
    if (delta <= 0) return 0;
    return 4.0 / 3.0 * p.effective_modulus * std::sqrt(r_eff * delta) * delta;
  }
  // The largest overlap of an undamped impact at the scale's speed (Johnson 1985, eq. 11.23):
  // delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5).
  static double peak_overlap(const Params& p, const ContactScale& s) {
    return std::pow(15.0 * s.mass * s.speed * s.speed /
                        (16.0 * p.effective_modulus * std::sqrt(s.radius)), 0.4);
  }
  // Hertz's t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5) (Johnson 1985, eq. 11.24) at the scale's speed.
  template <class Rate>
  static double contact_duration(const Params& p, const ContactScale& s, Rate&&) {
    return 2.868265 * std::pow(s.mass * s.mass / (s.radius * p.effective_modulus *
                                                   p.effective_modulus * s.speed), 0.2);
  }
  // The stiffest the contact gets in such an impact: S_n = 2 E* a at a = sqrt(R* delta_max).
  static NormalState stiffest(const Params& p, const ContactScale& s) {
    const double a = std::sqrt(s.radius * peak_overlap(p, s));
    return {2.0 * p.effective_modulus * a, a};
  }
};

}  // namespace tsubu
