// Stochastic surface roughness (the roughness seed note, eqs. 9-12; Sommerfeld 1992,
// Sommerfeld & Huber 1999): at first touch the contact normal n is tilted by a random scatter
// angle dG towards a random azimuth psi; the tilt is kept for the life of the contact.
//
// Random numbers come from Philox4x32-10 (Salmon et al., SC'11), a counter-based generator: a
// draw is a pure function of (seed, owner id, partner id or wall, first-touch step, attempt),
// so a run is reproducible whatever the thread count and neighbour-list schedule.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>

#include "../types.hpp"

namespace tsubu {

// Distribution of the roughness scatter angle dG (docs/roughness.md). (The values of a choice
// are the indices of its names in the option's declaration, option_table.hpp.)
enum class ScatterDistribution { Normal = 0, Uniform = 1 };
// Shadow effect at walls: which tilts a sphere can meet (docs/roughness.md).
enum class ShadowRule { Reject = 0, Weighted = 1, None = 2 };

// The parameter set (contact/parameters.hpp) of the roughness laws: a material's and a pair's.
struct RoughnessParams {
  double roughness = 0;  // standard deviation of the scatter angle dG, radians
  ScatterDistribution roughness_distribution = ScatterDistribution::Normal;
  ShadowRule shadow = ShadowRule::Reject;

  template <class V>
  static constexpr void fields(V&& visit) {
    visit("roughness", &RoughnessParams::roughness);
    visit("roughness_distribution", &RoughnessParams::roughness_distribution);
    visit("shadow", &RoughnessParams::shadow);
  }

  // The scatter of two independent surfaces adds in quadrature; the distribution and shadow
  // rule are those of the rougher material.
  template <class M>
  static void mix(const M& a, const M& b, RoughnessParams& p) {
    p.roughness = std::hypot(a.roughness, b.roughness);
    const M& rougher = b.roughness > a.roughness ? b : a;
    p.roughness_distribution = rougher.roughness_distribution;
    p.shadow = rougher.shadow;
  }
  static bool used(const RoughnessParams& p) { return p.roughness > 0; }
  // The largest sigma the distribution allows: |dG| < 90 degrees (uniform: sqrt(3) sigma < 90).
  static double limit(ScatterDistribution d) {
    return d == ScatterDistribution::Uniform ? 0.5 * M_PI / std::sqrt(3.0) : 0.5 * M_PI;
  }
};

// Smooth surfaces: the contact normal is the line of centres (or the wall's normal).
struct NoRoughness {
  static constexpr bool enabled = false;
  static constexpr const char* name = "";
  static constexpr int state_width = 0;
};
// Stochastic roughness: the normal is tilted by a random angle at first touch (engine/rough.hpp
// applies it). Per entry: walls: tilt vector (3), facet offset h, first-touch step; pairs:
// tilted normal n' (3; zero once enduring), facet offset H, first-touch step, spin term S.
struct StochasticRoughness {
  static constexpr bool enabled = true;
  static constexpr const char* name = "roughness";
  static constexpr int state_width = 6;
};

// Philox4x32 with 10 rounds: 4 x 32 random bits per (counter, key).
inline std::array<std::uint32_t, 4> philox4x32(std::array<std::uint32_t, 4> c,
                                               std::array<std::uint32_t, 2> k) {
  constexpr std::uint32_t M0 = 0xD2511F53u, M1 = 0xCD9E8D57u;
  constexpr std::uint32_t W0 = 0x9E3779B9u, W1 = 0xBB67AE85u;
  for (int round = 0; round < 10; ++round) {
    const std::uint64_t p0 = std::uint64_t(M0) * c[0], p1 = std::uint64_t(M1) * c[2];
    const std::uint32_t hi0 = std::uint32_t(p0 >> 32), lo0 = std::uint32_t(p0);
    const std::uint32_t hi1 = std::uint32_t(p1 >> 32), lo1 = std::uint32_t(p1);
    c = {hi1 ^ c[1] ^ k[0], lo1, hi0 ^ c[3] ^ k[1], lo0};
    k[0] += W0;
    k[1] += W1;
  }
  return c;
}

// A uniform double in (0, 1) from 32 random bits.
inline double uniform_open(std::uint32_t bits) { return (double(bits) + 0.5) * 0x1p-32; }

// The stream of one contact: which contact (owner, partner), when it began (step), and the
// attempt number of a rejection loop.
struct ContactStream {
  std::uint64_t seed;
  std::uint64_t owner;    // particle id
  std::uint64_t partner;  // particle id, or kWallTag + wall index + (triangle << 32)
  std::uint64_t step;     // step of first touch
  static constexpr std::uint64_t kWallTag = 0xFFFF0000u;

  std::array<double, 4> uniforms(std::uint32_t attempt) const {
    const auto r = philox4x32(
        {std::uint32_t(owner), std::uint32_t(partner), std::uint32_t(step),
         std::uint32_t((step >> 32) << 16) ^ attempt},
        {std::uint32_t(seed), std::uint32_t(seed >> 32) ^ std::uint32_t(owner >> 32)});
    return {uniform_open(r[0]), uniform_open(r[1]), uniform_open(r[2]), uniform_open(r[3])};
  }
};

// ---- the generators: each samples one quantity, documented in docs/roughness.md ----------

// dG ~ N(0, sigma) by Box-Muller from two uniforms (the caller rejects |dG| >= pi/2).
inline double scatter_normal(double sigma, double u1, double u2) {
  return sigma * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}
// dG ~ U(-sqrt(3) sigma, sqrt(3) sigma): the same standard deviation sigma.
inline double scatter_uniform(double sigma, double u1) {
  return std::sqrt(3.0) * sigma * (2.0 * u1 - 1.0);
}
// psi ~ U[0, 2 pi).
inline double azimuth_uniform(double u) { return 2.0 * M_PI * u; }

// The orthonormal basis {n1, n2} of the tangent plane of (11): n1 = normalise(n x a), a the
// coordinate axis least aligned with n; n2 = n x n1.
inline void tangent_basis(const Vec3& n, Vec3& n1, Vec3& n2) {
  const Vec3 a = n.cwiseAbs();
  const Vec3 axis = (a.x() <= a.y() && a.x() <= a.z()) ? Vec3::UnitX()
                    : (a.y() <= a.z())                 ? Vec3::UnitY()
                                                       : Vec3::UnitZ();
  n1 = n.cross(axis).normalized();
  n2 = n.cross(n1);
}

// dR = sin dG (sin psi n1 + cos psi n2) (11); n' = cos dG n + dR (12).
inline Vec3 tilt_vector(const Vec3& n, double scatter, double azimuth) {
  Vec3 n1, n2;
  tangent_basis(n, n1, n2);
  return std::sin(scatter) * (std::sin(azimuth) * n1 + std::cos(azimuth) * n2);
}

// Draws the tilt of a new contact with normal n. At walls (`wall`), the shadow rule applies to
// the approach velocity v (5): "reject" refuses tilts that the sphere would not approach
// (v . n' >= 0; for a tilt in the plane of incidence this is dG < -gamma, gamma of (9-10));
// "weighted" accepts a tilt with probability sin(gamma'), gamma' the incidence on the tilted
// plane (Sommerfeld & Huber 1999); "none" takes every draw. Draws with |dG| >= 90 degrees are
// redrawn. After 64 refused attempts the contact is smooth (tilt 0).
inline Vec3 draw_tilt(const RoughnessParams& p, const Vec3& n, const Vec3& v, bool wall,
                      const ContactStream& stream) {
  const double speed = v.norm();
  for (std::uint32_t attempt = 0; attempt < 64; ++attempt) {
    const auto u = stream.uniforms(attempt);
    const double scatter = p.roughness_distribution == ScatterDistribution::Uniform
                               ? scatter_uniform(p.roughness, u[0])
                               : scatter_normal(p.roughness, u[0], u[1]);
    if (!(std::abs(scatter) < 0.5 * M_PI)) continue;
    const Vec3 tilt = tilt_vector(n, scatter, azimuth_uniform(u[2]));
    if (wall && speed > 0 && p.shadow != ShadowRule::None) {
      const Vec3 np = std::cos(scatter) * n + tilt;
      const double sin_incidence = -v.dot(np) / speed;  // sin(gamma') on the tilted plane
      if (sin_incidence <= 0) continue;                 // the shadow: not reachable
      if (p.shadow == ShadowRule::Weighted && u[3] > sin_incidence) continue;
    }
    return tilt;
  }
  return Vec3::Zero();
}

// The tilted normal of a contact whose stored tilt vector is turned into the current tangent
// plane of n with its length |sin dG| kept (as the tangential history is).
inline Vec3 tilted_normal(const Vec3& n, double* tilt) {
  Eigen::Map<Vec3> t(tilt);
  const double len2 = t.squaredNorm();
  if (len2 == 0) return n;
  Vec3 rot = t - t.dot(n) * n;
  const double rot2 = rot.squaredNorm();
  if (rot2 > 0 && rot2 != len2) rot *= std::sqrt(len2 / rot2);
  t = rot;
  return std::sqrt(1.0 - len2) * n + rot;
}

}  // namespace tsubu
