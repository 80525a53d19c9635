// Normal elastic laws. A normal law owns its parameters and their mixing rule, its force in lane
// form, its elastic energy and the stiffness the time-step bounds use.
#pragma once
#include <cmath>

#include "geometry.hpp"

namespace tsubu {

// Linear spring f = k_n delta (1.6).
struct HookeNormal {
  static constexpr const char* name = "hooke";
  struct Params {
    double kn = 0;  // N/m
  };

  // Two half-springs in series: the harmonic mean, so that equal materials keep their value.
  template <class M>
  static void mix(const M& a, const M& b, Params& p) {
    p.kn = 2.0 * a.kn * b.kn / (a.kn + b.kn);
  }
  // The parameter a lane reads: k_n.
  static constexpr int kLaneParams = 1;
  static void pack(const Params& p, double* q) { q[0] = p.kn; }
  // f_n = k_n delta - eta_n v_n along n (1.6); not clipped at zero, as (B.9) assumes.
  TSUBU_INLINE static double lane(const double* q, double delta, double eta_n, double vn) {
    return mul_add(q[0], delta, -(eta_n * vn));
  }
  // 1/2 k_n delta^2: what the spring holds.
  static double elastic_energy(const Params& p, double delta) { return 0.5 * p.kn * delta * delta; }
  // The stiffness of the linearised spring at overlap delta (dF/d delta), for the stability bound
  // and the contact duration; the same for every overlap here.
  static double stiffness(const Params& p) { return p.kn; }
  // alpha = sqrt(k/m - eta^2 / 4m^2), the damped oscillation's angular frequency (B.3).
  static double oscillation_rate(const Params& p, double m, double eta) {
    return std::sqrt(p.kn / m - eta * eta / (4 * m * m));
  }

  // The forms the unit tests call: f_n from a measured contact.
  TSUBU_INLINE static double force(const ContactGeometry& g, const Params& p, double eta_n) {
    return lane(&p.kn, g.delta, eta_n, g.vn);
  }
};

}  // namespace tsubu
