// Normal contact: linear spring (1.6) with a dashpot whose coefficient comes from the
// restitution (B.9), using the reduced mass of the pair (walls: the particle's mass).
#pragma once
#include <cmath>

#include "../material.hpp"
#include "geometry.hpp"

namespace tsubu {

struct HookeNormal {
  // eta_n = -2 ln e sqrt(m k / (pi^2 + ln^2 e))   (B.9)
  static double damping(const PairParams& p, double m_eff) {
    return p.damping_factor * std::sqrt(m_eff * p.kn);
  }
  // f_n = k_n delta - eta_n v_n along n (1.6); not clipped at zero, as (B.9) assumes.
  TSUBU_INLINE static double force(double kn, double delta, double eta_n, double vn) {
    return mul_add(kn, delta, -(eta_n * vn));
  }
  TSUBU_INLINE static double force(const ContactGeometry& g, const PairParams& p, double eta_n) {
    return force(p.kn, g.delta, eta_n, g.vn);
  }
};

}  // namespace tsubu
