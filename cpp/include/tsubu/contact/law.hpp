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

  // The pair's parameters one lane needs (a block gathers them per contact).
  struct Params {
    double kn, kt, friction, tangential_damping;
  };

  // The normal and tangential laws of one contact in lane form (plain doubles, no branches): a
  // block of contacts runs it in a loop the compiler vectorises. Sets F (on i), n x F_t and the
  // dissipated power; updates the tangential displacement xi.
  TSUBU_INLINE static void lane(L3 n, L3 vt, double delta, double vn, double eta_n, const Params& p,
                                double dt, L3& xi, L3& force, L3& n_cross_ft, double& power) {
    const double fn = HookeNormal::force(p.kn, delta, eta_n, vn);
    force = fn * n;
    power = eta_n * vn * vn;
    if constexpr (Tangential::enabled) {
      const L3 ft = Tangential::lane(n, vt, p.kt, p.tangential_damping * eta_n,
                                     p.friction * std::abs(fn), dt, xi, power);
      force = force + ft;
      n_cross_ft = cross(n, ft);
    } else {
      (void)vt;
      (void)xi;
      (void)n_cross_ft;
    }
  }

  TSUBU_INLINE static void evaluate(const ContactGeometry& g, const PairParams& p, double dt, History& h,
                       ContactResult& out) {
    L3 xi{0, 0, 0}, force, nxft{0, 0, 0};
    if constexpr (has_history) xi = {h.xi[0], h.xi[1], h.xi[2]};
    lane(lanes(g.n), lanes(g.vt), g.delta, g.vn, g.eta_n,
         Params{p.kn, p.kt, p.friction, p.tangential_damping}, dt, xi, force, nxft, out.power);
    if constexpr (has_history) {
      h.xi[0] = xi.x;
      h.xi[1] = xi.y;
      h.xi[2] = xi.z;
    } else {
      (void)h;
    }
    out.fn = HookeNormal::force(g, p, g.eta_n);
    out.force = vec(force);
    out.n_cross_ft = vec(nxft);
    if constexpr (Rolling::enabled) out.roll = Rolling::evaluate(g, p, std::abs(out.fn), dt);
  }
};

}  // namespace tsubu
