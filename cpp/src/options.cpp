// The checks of every option a user sets (options.hpp): each range and message comes from the
// option's declaration (option_table.hpp), so that the C++ API, the bindings and the Python layer
// refuse the same values with the same words.
#include "tsubu/options.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>

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

// Every field of a material or a pair, by its declaration: its range (on the materials of its
// family), and, for a field that needs a Hertzian material, that rule.
template <class C>
void check_fields(const C& c, bool hertzian, const char* prefix) {
  for_each_declared_field<C>([&](const OptionDeclaration& d, auto member) {
    if constexpr (std::is_same_v<member_type<decltype(member)>, double>) {
      if ((d.checked_for == OptionFamily::Linear && hertzian) ||
          (d.checked_for == OptionFamily::Hertzian && !hertzian))
        return;
      const double value = c.*member;
      check_declared(d, value, prefix);
      require(!*d.needs_hertzian || !(value > 0) || hertzian, [&] {
        return std::string(prefix) + d.name + " > 0 needs youngs_modulus (" + d.needs_hertzian +
               "), got " + d.name + " " + fmt(value) + " for a linear " +
               (*prefix ? "pair" : "material");
      });
    }
  });
  // A cross-option rule: a uniform draw spans +-sqrt(3) sigma, which must stay below 90 degrees.
  require(c.roughness_distribution != ScatterDistribution::Uniform ||
              std::sqrt(3.0) * c.roughness < 0.5 * M_PI,
          [&] {
            return std::string(prefix) +
                   "roughness with a uniform distribution must be < 90/sqrt(3) degrees, got " +
                   fmt(c.roughness * 180 / M_PI) + " degrees";
          });
}

}  // namespace

void validate_material(const Material& m) { check_fields(m, HertzMaterial::used(m), ""); }

void validate_pair(const PairParams& p) { check_fields(p, HertzParams::used(p), "pair "); }

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
  for_each_law_choice([&](const OptionDeclaration& d, std::size_t slot) {
    const int k = o.law_choices[slot];
    require(k >= 0 && static_cast<std::size_t>(k) < choice_count(d.choices),
            [&] { return std::string(d.name) + " is not one of its choices, got " + std::to_string(k); });
  });
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
  for_each_law_choice([&](const OptionDeclaration& d, std::size_t slot) { w.integer(d.name, law_choices[slot]); });
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
  for_each_law_choice([&](const OptionDeclaration& d, std::size_t slot) {
    law_choices[slot] = static_cast<int>(in(d.name, 0, static_cast<std::int64_t>(choice_count(d.choices)) - 1));
  });
  impact_speed = r.real("impact_speed");
}

}  // namespace tsubu
