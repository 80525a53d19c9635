// Rolling resistance (1.20): M_ij = -mu_r r_i |f_n| (w_i - w_j)/|w_i - w_j|.
#pragma once
#include <algorithm>
#include <cmath>

#include "../material.hpp"
#include "geometry.hpp"

namespace tsubu {

struct NoRolling {
  static constexpr bool enabled = false;
  static constexpr const char* name = "none";
};

struct RollingFriction {
  static constexpr bool enabled = true;
  static constexpr const char* name = "rolling";

  // Returns R with M_ij = r_i R and M_ji = -r_j R. Its size is capped so that, alone, it at most
  // stops the relative spin within this step and never reverses it.
  TSUBU_INLINE static Vec3 evaluate(const ContactGeometry& g, const PairParams& p, double fn_abs, double dt) {
    const double w = g.w_rel.norm();
    if (w == 0 || p.rolling_friction == 0) return Vec3::Zero();
    const double q = std::min(p.rolling_friction * fn_abs, w / (dt * g.spin_mobility));
    return (-q / w) * g.w_rel;
  }
};

}  // namespace tsubu
