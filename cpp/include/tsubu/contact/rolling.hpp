// Rolling resistance (1.20): M_ij = -mu_r r_i |f_n| (w_i - w_j)/|w_i - w_j|.
#pragma once
#include <algorithm>
#include <cmath>

#include "geometry.hpp"

namespace tsubu {

// The parameter set (contact/parameters.hpp) of the rolling laws: a material's and a pair's.
struct RollingParams {
  double rolling_friction = 0;  // mu_r of (1.20), dimensionless

  template <class V>
  static constexpr void fields(V&& visit) { visit("rolling_friction", &RollingParams::rolling_friction); }

  template <class M>
  static void mix(const M& a, const M& b, RollingParams& p) {
    p.rolling_friction = std::sqrt(a.rolling_friction * b.rolling_friction);  // geometric mean
  }
  static bool used(const RollingParams& p) { return p.rolling_friction > 0; }
};

struct NoRolling {
  static constexpr bool enabled = false;
  static constexpr const char* name = "";
};

struct RollingFriction {
  static constexpr bool enabled = true;
  static constexpr const char* name = "rolling";

  // Returns R with M_ij = r_i R and M_ji = -r_j R. Its size is capped so that, alone, it at most
  // stops the relative spin within this step and never reverses it.
  TSUBU_INLINE static Vec3 evaluate(const ContactGeometry& g, const RollingParams& p, double fn_abs, double dt) {
    const double w = g.w_rel.norm();
    if (w == 0 || p.rolling_friction == 0) return Vec3::Zero();
    const double q = std::min(p.rolling_friction * fn_abs, w / (dt * g.spin_mobility));
    return (-q / w) * g.w_rel;
  }
};

}  // namespace tsubu
