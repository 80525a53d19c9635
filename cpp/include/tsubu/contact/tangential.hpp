// Tangential contact laws: spring-dashpot on the accumulated tangential displacement (1.11,
// 1.13-1.16) with the Coulomb cap (1.17-1.18). Each law owns the history it needs.
#pragma once
#include <algorithm>
#include <cmath>

#include "../material.hpp"
#include "geometry.hpp"

namespace tsubu {

// Frictionless contacts: no tangential force, no history, no angular-velocity reads.
struct NoTangential {
  static constexpr bool enabled = false;
  static constexpr const char* name = "none";
  struct History {};
};

namespace detail {
// Coulomb cap (1.17)-(1.18) shared by the history laws. `xi_trial` holds the displacement with
// this step's increment; `xi_frozen` the displacement without it. When the trial force exceeds
// mu |f_n| the contact slips: the force is mu |f_n| along -t, t = v_t/|v_t| (DESIGN.md note 1:
// |f_n|, not |f_t|), and the displacement stays frozen (1.18).
template <bool kTruncate = false>
TSUBU_INLINE Vec3 coulomb(const ContactGeometry& g, const PairParams& p, double eta_t, double fn_abs,
                    double dt, const Vec3& xi_trial, const Vec3& xi_frozen, double* xi,
                    double& power) {
  Vec3 ft = -p.kt * xi_trial - eta_t * g.vt;  // (1.11)
  const double cap = p.friction * fn_abs;
  const double ft2 = ft.squaredNorm();
  if constexpr (kTruncate) {
    // The rule of LAMMPS (gran/hooke/history) and SCENE.md: the trial force is scaled down to
    // the cap in its own direction, and the displacement truncated to match.
    if (ft2 > cap * cap) {
      ft *= cap / std::sqrt(ft2);
      const Vec3 cut = -(ft + eta_t * g.vt) / p.kt;
      std::copy(cut.data(), cut.data() + 3, xi);
      // dissipated = work against the slip + the spring energy cut off
      power += -ft.dot(g.vt) + 0.5 * p.kt * (xi_frozen.squaredNorm() - cut.squaredNorm()) / dt;
    } else {
      std::copy(xi_trial.data(), xi_trial.data() + 3, xi);
      power += eta_t * g.vt.squaredNorm();
    }
    return ft;
  }
  if (ft2 > cap * cap) {
    const double vt = g.vt.norm();
    // Slip direction -t; if v_t vanishes the spring alone broke the cap: keep its direction.
    ft = (vt > 0) ? Vec3(-cap / vt * g.vt) : Vec3(cap / std::sqrt(ft2) * ft);
    std::copy(xi_frozen.data(), xi_frozen.data() + 3, xi);
    power += -ft.dot(g.vt);
  } else {
    std::copy(xi_trial.data(), xi_trial.data() + 3, xi);
    power += eta_t * g.vt.squaredNorm();
  }
  return ft;
}
}  // namespace detail

// Default rule (DESIGN.md note 3): the stored displacement is a vector, rotated into the current
// tangent plane each step with its length kept, then incremented by v_t dt. kTruncate selects
// the slip rule: false, the notes' (1.17)-(1.18) (default); true, LAMMPS's (for comparisons).
template <bool kTruncate>
struct TangentialRotateRule {
  static constexpr bool enabled = true;
  static constexpr const char* name = kTruncate ? "rotate, truncate" : "rotate";
  struct History { double xi[3]; };

  TSUBU_INLINE static Vec3 evaluate(const ContactGeometry& g, const PairParams& p, double eta_t, double fn_abs,
                       double dt, History& h, double& power) {
    const Vec3 old = Eigen::Map<const Vec3>(h.xi);
    const double along = old.dot(g.n);
    Vec3 rot = old - along * g.n;
    const double len2 = old.squaredNorm();
    if (along != 0) {
      // Rescale to the old length: sqrt(len2 / rot2) = (1 - eps)^(-1/2), eps = along^2 / len2.
      // Each step turns the plane by a tiny angle, so the series (error < eps^3 / 3, below
      // rounding for eps < 1e-5) spares a square root on the critical path.
      const double eps = along * along / len2;
      const double rot2 = rot.squaredNorm();
      if (eps < 1e-5)
        rot *= 1.0 + eps * (0.5 + 0.375 * eps);
      else if (rot2 > 0)
        rot *= std::sqrt(len2 / rot2);
    }
    const Vec3 trial = rot + g.vt * dt;  // (1.13) one step
    return detail::coulomb<kTruncate>(g, p, eta_t, fn_abs, dt, trial, rot, h.xi, power);
  }
};
using TangentialRotate = TangentialRotateRule<false>;
using TangentialRotateTruncate = TangentialRotateRule<true>;

// The notes' literal rule (1.14)-(1.16): the whole accumulated length is re-aimed along the
// current t = v_t/|v_t| and grows by |v_t| dt; unchanged when v_t = 0. Kept for comparison only:
// its spring never unloads (docs/physics.md shows the difference).
struct TangentialLiteral {
  static constexpr bool enabled = true;
  static constexpr const char* name = "literal";
  struct History { double xi[3]; };

  TSUBU_INLINE static Vec3 evaluate(const ContactGeometry& g, const PairParams& p, double eta_t, double fn_abs,
                       double dt, History& h, double& power) {
    const Vec3 old = Eigen::Map<const Vec3>(h.xi);
    const double vt = g.vt.norm();
    const Vec3 trial = (vt > 0) ? Vec3((old.norm() + vt * dt) / vt * g.vt) : old;  // (1.14), (1.16)
    return detail::coulomb(g, p, eta_t, fn_abs, dt, trial, old, h.xi, power);
  }
};

}  // namespace tsubu
