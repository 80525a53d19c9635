// The checks of every option a user sets (options.hpp).
#include "tsubu/options.hpp"

#include <cmath>

#include "check.hpp"

namespace tsubu {

using detail::fmt;
using detail::require;

void validate_material(const Material& m) {
  require(m.density > 0 && std::isfinite(m.density), "density must be > 0, got " + fmt(m.density));
  require(m.youngs_modulus >= 0 && std::isfinite(m.youngs_modulus),
          "youngs_modulus must be > 0 (or 0 for a linear material), got " + fmt(m.youngs_modulus));
  if (m.youngs_modulus > 0) {
    require(m.poisson_ratio > -1 && m.poisson_ratio <= 0.5,
            "poisson_ratio must be in (-1, 0.5], got " + fmt(m.poisson_ratio));
  } else {
    require(m.kn > 0 && std::isfinite(m.kn), "kn must be > 0, got " + fmt(m.kn));
    require(m.kt >= 0 && std::isfinite(m.kt), "kt must be >= 0, got " + fmt(m.kt));
  }
  require(m.restitution > 0 && m.restitution <= 1,
          "restitution must be in (0, 1], got " + fmt(m.restitution));
  require(m.friction >= 0 && std::isfinite(m.friction),
          "friction must be >= 0, got " + fmt(m.friction));
  require(m.rolling_friction >= 0 && std::isfinite(m.rolling_friction),
          "rolling_friction must be >= 0, got " + fmt(m.rolling_friction));
  require(m.tangential_damping >= 0 && std::isfinite(m.tangential_damping),
          "tangential_damping must be >= 0, got " + fmt(m.tangential_damping));
  require(m.roughness >= 0 && m.roughness < 0.5 * M_PI,
          "roughness must be in [0, pi/2) radians, got " + fmt(m.roughness));
}

void validate_pair(const PairParams& p) {
  if (HertzParams::used(p))
    require(std::isfinite(p.effective_modulus) && p.effective_shear_modulus >= 0 &&
                std::isfinite(p.effective_shear_modulus),
            "pair moduli must be effective_modulus > 0, effective_shear_modulus >= 0");
  else
    require(p.kn > 0 && p.kt >= 0, "pair stiffnesses must be kn > 0, kt >= 0");
  require(p.restitution > 0 && p.restitution <= 1, "pair restitution must be in (0, 1]");
  require(p.friction >= 0 && p.rolling_friction >= 0 && p.tangential_damping >= 0,
          "pair friction coefficients must be >= 0");
  require(p.roughness >= 0 && p.roughness < 0.5 * M_PI, "pair roughness must be in [0, pi/2)");
  require(p.roughness_distribution != ScatterDistribution::Uniform ||
              std::sqrt(3.0) * p.roughness < 0.5 * M_PI,
          "pair roughness with a uniform distribution must be < 90/sqrt(3) degrees, got " +
              fmt(p.roughness * 180 / M_PI) + " degrees");
}

void validate_options(const Options& o) {
  require(o.gravity.allFinite(), "gravity is not finite");
  require(o.max_overlap > 0, "max_overlap must be > 0");
  require(!(o.slip == SlipRule::Truncate && o.history == HistoryRule::Literal),
          "the truncate slip rule needs the rotate tangential history");
}

}  // namespace tsubu
