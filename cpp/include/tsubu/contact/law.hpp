// One contact law = the normal law plus one choice per optional slot, combined at compile time.
// The loop (step.hpp) is a template over it, so a slot that a scene does not use costs nothing.
#pragma once
#include <cmath>

#include "geometry.hpp"
#include "normal.hpp"
#include "rolling.hpp"
#include "tangential.hpp"

namespace tsubu {

// Smooth surfaces: the contact normal is the line of centres (or the wall's normal).
struct NoRoughness {
  static constexpr bool enabled = false;
};
// Stochastic roughness (roughness.hpp): the normal is tilted by a random angle at first touch.
struct StochasticRoughness {
  static constexpr bool enabled = true;
};

template <class Tangential, class Rolling, class Roughness = NoRoughness>
struct ContactLaw {
  using tangential = Tangential;
  using rolling = Rolling;
  using roughness = Roughness;
  using History = typename Tangential::History;
  static constexpr bool has_history = Tangential::enabled;
  // A tilted normal gives torque even without friction.
  static constexpr bool has_torque = Tangential::enabled || Rolling::enabled || Roughness::enabled;

  TSUBU_INLINE static void evaluate(const ContactGeometry& g, const PairParams& p, double dt, History& h,
                       ContactResult& out) {
    const double eta_n = g.eta_n;
    out.fn = HookeNormal::force(g, p, eta_n);
    out.force = out.fn * g.n;
    out.power = eta_n * g.vn * g.vn;
    const double fn_abs = std::abs(out.fn);
    if constexpr (Tangential::enabled) {
      const Vec3 ft =
          Tangential::evaluate(g, p, p.tangential_damping * eta_n, fn_abs, dt, h, out.power);
      out.force += ft;
      out.n_cross_ft = g.n.cross(ft);
    } else {
      (void)h;
    }
    if constexpr (Rolling::enabled) out.roll = Rolling::evaluate(g, p, fn_abs, dt);
  }
};

}  // namespace tsubu
