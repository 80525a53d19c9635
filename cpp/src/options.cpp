// The checks of every option a user sets (options.hpp): each range and message comes from the
// option's declaration (option_table.hpp), so that the C++ API, the bindings and the Python layer
// refuse the same values with the same words.
#include "tsubu/options.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "check.hpp"
#include "tsubu/option_table.hpp"

namespace tsubu {

using detail::fmt;
using detail::require;

std::string declared_range(const OptionDeclaration& d) {
  const bool lo = std::isfinite(d.minimum), hi = std::isfinite(d.maximum);
  const double s = d.scale;
  std::string text;
  if (lo && hi)
    text = std::string("in ") + (d.exclusive_minimum ? "(" : "[") + fmt(d.minimum * s) + ", " +
           fmt(d.maximum * s) + (d.exclusive_maximum ? ")" : "]");
  else if (lo)
    text = std::string("a finite number ") + (d.exclusive_minimum ? "> " : ">= ") + fmt(d.minimum * s);
  else if (hi)
    text = std::string("a finite number ") + (d.exclusive_maximum ? "< " : "<= ") + fmt(d.maximum * s);
  else
    text = "finite";
  if (*d.core_unit) text += std::string(" ") + d.core_unit;
  if (*d.zero_means) text += std::string(" (or 0 for ") + d.zero_means + ")";
  return text;
}

void check_declared(const OptionDeclaration& d, double core_value, const char* prefix) {
  if (*d.zero_means && core_value == 0) return;
  require(in_declared_range(d, core_value), [&] {
    if (d.kind == OptionKind::Integer)  // the bound it is beyond, as Python's checks say it
      return std::string(prefix) + d.name + " must be " +
             (core_value < d.minimum ? ">= " + std::to_string(static_cast<long long>(d.minimum))
                                     : "<= " + std::to_string(d.integer_maximum)) +
             ", got " + std::to_string(static_cast<long long>(core_value));
    return std::string(prefix) + d.name + " must be " + declared_range(d) + ", got " +
           fmt(core_value);
  });
}

namespace {

// The check of the option `name` (its declaration found at compile time) on `value`.
#define TSUBU_CHECK(name, value, prefix)                                       \
  do {                                                                         \
    constexpr const OptionDeclaration& declaration = option_declaration(name); \
    check_declared(declaration, static_cast<double>(value), prefix);           \
  } while (0)

// The fields a material and a pair share (each law's parameters).
template <class P>
void check_law_fields(const P& p, bool hertzian, const char* prefix) {
  if (!hertzian) {
    TSUBU_CHECK("kn", p.kn, prefix);
    TSUBU_CHECK("kt", p.kt, prefix);
  }
  TSUBU_CHECK("restitution", p.restitution, prefix);
  TSUBU_CHECK("friction", p.friction, prefix);
  TSUBU_CHECK("rolling_friction", p.rolling_friction, prefix);
  TSUBU_CHECK("tangential_damping", p.tangential_damping, prefix);
  TSUBU_CHECK("roughness", p.roughness, prefix);
  TSUBU_CHECK("work_of_adhesion", p.work_of_adhesion, prefix);
  require(!(p.work_of_adhesion > 0) || hertzian, [&] {
    return std::string(prefix) +
           "work_of_adhesion > 0 needs youngs_modulus (adhesion is offered on Hertz's law), got "
           "work_of_adhesion " + fmt(p.work_of_adhesion) + " for a linear " +
           (*prefix ? "pair" : "material");
  });
  // A cross-option rule: a uniform draw spans +-sqrt(3) sigma, which must stay below 90 degrees.
  require(p.roughness_distribution != ScatterDistribution::Uniform ||
              std::sqrt(3.0) * p.roughness < 0.5 * M_PI,
          [&] {
            return std::string(prefix) +
                   "roughness with a uniform distribution must be < 90/sqrt(3) degrees, got " +
                   fmt(p.roughness * 180 / M_PI) + " degrees";
          });
}

}  // namespace

void validate_material(const Material& m) {
  TSUBU_CHECK("density", m.density, "");
  TSUBU_CHECK("youngs_modulus", m.youngs_modulus, "");
  const bool hertzian = m.youngs_modulus > 0;
  if (hertzian) TSUBU_CHECK("poisson_ratio", m.poisson_ratio, "");
  check_law_fields(m, hertzian, "");
}

void validate_pair(const PairParams& p) {
  TSUBU_CHECK("effective_modulus", p.effective_modulus, "pair ");
  const bool hertzian = HertzParams::used(p);
  if (hertzian) TSUBU_CHECK("effective_shear_modulus", p.effective_shear_modulus, "pair ");
  check_law_fields(p, hertzian, "pair ");
}

void validate_options(const Options& o) {
  require(o.gravity.allFinite(), "gravity is not finite");
  TSUBU_CHECK("dt", o.dt, "");
  TSUBU_CHECK("threads", o.threads, "");
  TSUBU_CHECK("parallel_min", o.parallel_min, "");
  TSUBU_CHECK("skin", o.skin, "");
  TSUBU_CHECK("impact_speed", o.impact_speed, "");
  TSUBU_CHECK("max_overlap", o.max_overlap, "");
  TSUBU_CHECK("initial_overlap", o.initial_overlap, "");
  require(!(o.slip == SlipRule::Truncate && o.history == HistoryRule::Literal),
          "the truncate slip rule needs the rotate tangential history");
}

#undef TSUBU_CHECK

// ---- checkpoints ------------------------------------------------------------------------------

void Options::save(archive::Writer& w) const {
  w.vec3("gravity", gravity);
  w.real("dt", dt);
  w.integer("threads", threads);
  w.integer("parallel_min", parallel_min);
  w.real("skin", skin);
  w.integer("history", static_cast<int>(history));
  w.integer("slip", static_cast<int>(slip));
  w.real("max_overlap", max_overlap);
  w.real("initial_overlap", initial_overlap);
  w.integer("allow_unstable_dt", allow_unstable_dt);
  w.integer("rebuild_every_step", rebuild_every_step);
  w.integer("seed", static_cast<std::int64_t>(seed));  // two's complement: the same 64 bits back
  w.integer("repulsive", repulsive);
  w.integer("adhesion", static_cast<int>(adhesion));
  w.real("impact_speed", impact_speed);
}

void Options::restore(archive::Reader& r) {
  auto flag = [&](const char* name) {
    const std::int64_t v = r.integer(name);
    if (v != 0 && v != 1) r.fail(std::string(name) + " must be 0 or 1, got " + std::to_string(v));
    return v == 1;
  };
  auto in = [&](const char* name, std::int64_t lo, std::int64_t hi) {
    const std::int64_t v = r.integer(name);
    if (v < lo || v > hi)
      r.fail(std::string(name) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
             "], got " + std::to_string(v));
    return v;
  };
  gravity = r.vec3("gravity");
  dt = r.real("dt");
  threads = static_cast<int>(in("threads", 0, 1 << 20));
  parallel_min = static_cast<int>(in("parallel_min", 0, std::numeric_limits<int>::max()));
  skin = r.real("skin");
  history = static_cast<HistoryRule>(in("history", 0, 1));
  slip = static_cast<SlipRule>(in("slip", 0, 1));
  max_overlap = r.real("max_overlap");
  initial_overlap = r.real("initial_overlap");
  allow_unstable_dt = flag("allow_unstable_dt");
  rebuild_every_step = flag("rebuild_every_step");
  seed = static_cast<std::uint64_t>(r.integer("seed"));
  repulsive = flag("repulsive");
  adhesion = static_cast<AdhesionLaw>(in("adhesion", 0, 1));
  impact_speed = r.real("impact_speed");
}

}  // namespace tsubu
