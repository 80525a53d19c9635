// Materials and the per-pair contact parameters mixed from them once, at set-up.
#pragma once
#include <cmath>
#include <vector>

#include "types.hpp"

namespace tsubu {

// Distribution of the roughness scatter angle dG (docs/roughness.md).
enum class ScatterDistribution { Normal = 0, Uniform = 1 };
// Shadow effect at walls: which tilts a sphere can meet (docs/roughness.md).
enum class ShadowRule { Reject = 0, Weighted = 1, None = 2 };

// One material: every sphere and every wall has one.
struct Material {
  double density = 2500.0;          // kg/m^3 (walls: unused)
  double kn = 1.0e3;                // normal stiffness, N/m
  double kt = 2.0 / 7.0 * 1.0e3;    // tangential stiffness, N/m
  double restitution = 0.5;         // normal coefficient of restitution, (0, 1]
  double friction = 0.5;            // Coulomb coefficient mu (1.17)
  double rolling_friction = 0.0;    // mu_r of (1.20), dimensionless
  double tangential_damping = 0.0;  // eta_t / eta_n
  double roughness = 0.0;           // standard deviation of the scatter angle dG, radians
  ScatterDistribution roughness_distribution = ScatterDistribution::Normal;
  ShadowRule shadow = ShadowRule::Reject;
};

// Parameters of one contact between two materials (or a material and a wall's material).
struct PairParams {
  double kn = 0, kt = 0;
  double restitution = 1;
  double friction = 0, rolling_friction = 0;
  double tangential_damping = 0;
  double roughness = 0;  // radians
  ScatterDistribution roughness_distribution = ScatterDistribution::Normal;
  ShadowRule shadow = ShadowRule::Reject;
  // (B.9) written as eta_n = damping_factor * sqrt(m_eff * kn), so a contact needs one sqrt.
  double damping_factor = 0;

  void finalise() {
    const double le = std::log(restitution);
    damping_factor = -2.0 * le / std::sqrt(M_PI * M_PI + le * le);
  }
};

// The mixing rule (documented in docs/physics.md): stiffnesses combine as two half-springs in
// series (harmonic mean, so equal materials keep their own value); restitution, friction,
// rolling friction and the tangential damping ratio take the geometric mean; the roughness
// scatter of two independent surfaces adds in quadrature, sigma = sqrt(sigma_a^2 + sigma_b^2),
// and the distribution and shadow rule are those of the rougher material.
inline PairParams mix(const Material& a, const Material& b) {
  PairParams p;
  auto harmonic = [](double x, double y) { return 2.0 * x * y / (x + y); };
  p.kn = harmonic(a.kn, b.kn);
  p.kt = (a.kt == 0 || b.kt == 0) ? 0.0 : harmonic(a.kt, b.kt);
  p.restitution = std::sqrt(a.restitution * b.restitution);
  p.friction = std::sqrt(a.friction * b.friction);
  p.rolling_friction = std::sqrt(a.rolling_friction * b.rolling_friction);
  p.tangential_damping = std::sqrt(a.tangential_damping * b.tangential_damping);
  p.roughness = std::hypot(a.roughness, b.roughness);
  const Material& rougher = b.roughness > a.roughness ? b : a;
  p.roughness_distribution = rougher.roughness_distribution;
  p.shadow = rougher.shadow;
  p.finalise();
  return p;
}

// Symmetric table of PairParams indexed by material pair; rebuilt when materials change.
class PairTable {
 public:
  void resize(std::size_t n) {
    n_ = n;
    table_.assign(n * n, PairParams{});
  }
  std::size_t size() const { return n_; }
  const PairParams& operator()(std::size_t a, std::size_t b) const { return table_[a * n_ + b]; }
  void set(std::size_t a, std::size_t b, const PairParams& p) {
    table_[a * n_ + b] = p;
    table_[b * n_ + a] = p;
  }

 private:
  std::size_t n_ = 0;
  std::vector<PairParams> table_;
};

}  // namespace tsubu
