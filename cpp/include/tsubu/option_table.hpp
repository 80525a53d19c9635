// Every option a user sets, declared once: the material fields, the per-pair overrides and the
// run options, each with its name, unit, range, default and a one-line doc. The C++ checks
// (options.cpp), the Python validation (python/tsubu/_options.py reads this table through
// _core.option_table()), the scene format's spec, JSON Schema and reference
// (python/tsubu/scene/spec.py) all follow from it; tests/test_option_declarations.py checks that
// they agree (and that the defaults are the structs' own).
//
// Ranges and defaults are in the Python API's units (`unit`); the core stores `scale` x that
// value (roughness: degrees in Python and scene files, radians in the core).
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include "contact/roughness.hpp"
#include "options.hpp"

namespace tsubu {

// The names of each string-valued option's choices (the first is the default), one table per
// enum: the bindings parse and print the enums with these.
inline constexpr std::array<std::pair<const char*, ScatterDistribution>, 2> kScatterDistributionNames{
    {{"normal", ScatterDistribution::Normal}, {"uniform", ScatterDistribution::Uniform}}};
inline constexpr std::array<std::pair<const char*, ShadowRule>, 3> kShadowRuleNames{
    {{"reject", ShadowRule::Reject}, {"weighted", ShadowRule::Weighted}, {"none", ShadowRule::None}}};
inline constexpr std::array<std::pair<const char*, HistoryRule>, 2> kHistoryRuleNames{
    {{"rotate", HistoryRule::Rotate}, {"literal", HistoryRule::Literal}}};
inline constexpr std::array<std::pair<const char*, SlipRule>, 2> kSlipRuleNames{
    {{"frozen", SlipRule::Frozen}, {"truncate", SlipRule::Truncate}}};
inline constexpr std::array<std::pair<const char*, AdhesionLaw>, 2> kAdhesionLawNames{
    {{"jkr", AdhesionLaw::Jkr}, {"dmt", AdhesionLaw::Dmt}}};

// Where an option is set (a bit mask): a Material field, a per-pair override
// (Simulation::set_pair_parameters), or an option of the run (Options, Simulation's constructor).
enum OptionScope : unsigned { kMaterial = 1, kPair = 2, kRun = 4 };
// What an option's value is.
enum class OptionKind { Real, Integer, Flag, Choice, Vector };

constexpr std::size_t kMaxChoices = 4;
using ChoiceNames = std::array<const char*, kMaxChoices>;  // unused entries are nullptr

template <class E, std::size_t N>
constexpr ChoiceNames choice_names(const std::array<std::pair<const char*, E>, N>& table) {
  static_assert(N <= kMaxChoices, "raise kMaxChoices");
  ChoiceNames out{};
  for (std::size_t k = 0; k < N; ++k) out[k] = table[k].first;
  return out;
}

struct OptionDeclaration {
  const char* name;  // as Python, scene files and messages spell it
  unsigned scopes;   // OptionScope bits
  OptionKind kind;
  const char* unit;  // in the Python API ("" for a dimensionless number)
  // The accepted range of a Real or Integer (an infinite bound: none), each end open or closed.
  double minimum = -std::numeric_limits<double>::infinity();
  double maximum = std::numeric_limits<double>::infinity();
  bool exclusive_minimum = false;
  bool exclusive_maximum = false;
  // Non-empty: the core stores 0 for "not given" (Python's None), meaning this.
  const char* zero_means = "";
  double default_value = 0;  // a Real's, Integer's or Flag's (1: true); a Choice's is choices[0]
  const char* default_text = "";  // the default as the docs say it
  const char* doc = "";           // one line
  ChoiceNames choices{};
  double scale = 1;               // core value = scale x the value in `unit`
  const char* core_unit = "";     // the core's unit where scale != 1
  std::uint64_t integer_maximum = 0;  // an Integer's maximum, exactly (2^64 - 1 is not a double)
};

namespace option_detail {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr unsigned kLaw = kMaterial | kPair;

// A number's declaration: its range, default, doc and what the core's 0 means.
constexpr OptionDeclaration number(OptionDeclaration d, double lo, bool lo_open, double hi,
                                   bool hi_open, double value, const char* text, const char* doc,
                                   const char* zero_means) {
  d.minimum = lo;
  d.exclusive_minimum = lo_open;
  d.maximum = hi;
  d.exclusive_maximum = hi_open;
  d.default_value = value;
  d.default_text = text;
  d.doc = doc;
  d.zero_means = zero_means;
  return d;
}
constexpr OptionDeclaration real(const char* name, unsigned scopes, const char* unit, double lo,
                                 bool lo_open, double hi, bool hi_open, double value,
                                 const char* text, const char* doc, const char* zero_means = "") {
  return number({name, scopes, OptionKind::Real, unit}, lo, lo_open, hi, hi_open, value, text, doc,
                zero_means);
}
constexpr OptionDeclaration integer(const char* name, std::uint64_t lo, std::uint64_t hi,
                                    double value, const char* text, const char* doc,
                                    const char* zero_means = "") {
  OptionDeclaration d = number({name, kRun, OptionKind::Integer, ""}, static_cast<double>(lo),
                               false, static_cast<double>(hi), false, value, text, doc, zero_means);
  d.integer_maximum = hi;
  return d;
}
constexpr OptionDeclaration choice(const char* name, unsigned scopes, ChoiceNames names,
                                   const char* text, const char* doc) {
  OptionDeclaration d{name, scopes, OptionKind::Choice, ""};
  d.choices = names;
  d.default_text = text;
  d.doc = doc;
  return d;
}
constexpr OptionDeclaration flag(const char* name, const char* doc) {
  OptionDeclaration d{name, kRun, OptionKind::Flag, ""};
  d.default_text = "false";
  d.doc = doc;
  return d;
}
constexpr OptionDeclaration degrees(OptionDeclaration d) {
  d.scale = M_PI / 180;
  d.core_unit = "radians";
  return d;
}
}  // namespace option_detail

// The table. Order: the materials' fields, the pairs' own, the run's.
inline constexpr OptionDeclaration kOptionTable[] = {
    // ---- materials (and, where kLaw, pair overrides) ----
    option_detail::real("density", kMaterial, "kg/m^3", 0, true, option_detail::kInf, false, 2500,
                        "2500", "Mass density."),
    option_detail::real("kn", option_detail::kLaw, "N/m", 0, true, option_detail::kInf, false, 1e3,
                        "1e3 for a linear material",
                        "Normal spring stiffness of the linear (Kelvin-Voigt) law."),
    option_detail::real("kt", option_detail::kLaw, "N/m", 0, false, option_detail::kInf, false,
                        2.0 / 7.0 * 1e3, "2/7 kn", "Tangential spring stiffness of the linear law."),
    option_detail::real("youngs_modulus", kMaterial, "Pa", 0, true, option_detail::kInf, false, 0,
                        "none (linear)",
                        "Young's modulus E: makes the material Hertz-Mindlin (then kn, kt must not "
                        "be given).",
                        "a linear material"),
    option_detail::real("poisson_ratio", kMaterial, "", -1, true, 0.5, false, 0.3,
                        "0.3 with youngs_modulus", "Poisson's ratio of a Hertzian material."),
    option_detail::real("restitution", option_detail::kLaw, "", 0, true, 1, false, 0.5, "0.5",
                        "Normal coefficient of restitution."),
    option_detail::real("friction", option_detail::kLaw, "", 0, false, option_detail::kInf, false,
                        0.5, "0.5", "Coulomb friction coefficient (0: frictionless)."),
    option_detail::real("rolling_friction", option_detail::kLaw, "", 0, false, option_detail::kInf,
                        false, 0, "0", "Rolling friction coefficient."),
    option_detail::real("tangential_damping", option_detail::kLaw, "", 0, false,
                        option_detail::kInf, false, 0, "0",
                        "Tangential dashpot as a fraction of the normal one."),
    option_detail::degrees(option_detail::real(
        "roughness", option_detail::kLaw, "degrees", 0, false, 90, true, 0, "0",
        "Standard deviation of the roughness scatter angle (docs/roughness.md).")),
    option_detail::real("work_of_adhesion", option_detail::kLaw, "J/m^2", 0, false,
                        option_detail::kInf, false, 0, "0",
                        "Work of adhesion of two surfaces (2 x the surface energy) of a Hertzian "
                        "material: JKR or DMT (docs/physics.md)."),
    option_detail::choice("roughness_distribution", option_detail::kLaw,
                          choice_names(kScatterDistributionNames), "\"normal\"",
                          "Distribution of the roughness tilt."),
    option_detail::choice("shadow", option_detail::kLaw, choice_names(kShadowRuleNames),
                          "\"reject\"", "Shadow effect at walls (docs/roughness.md)."),
    // ---- pairs only ----
    option_detail::real("effective_modulus", kPair, "Pa", 0, true, option_detail::kInf, false, 0,
                        "mixed", "E* of a pair of Hertzian materials.", "a linear pair"),
    option_detail::real("effective_shear_modulus", kPair, "Pa", 0, false, option_detail::kInf,
                        false, 0, "mixed", "G* of a pair of Hertzian materials."),
    // ---- the run ----
    [] {
      OptionDeclaration d{"gravity", kRun, OptionKind::Vector, "m/s^2"};
      d.default_text = "[0, 0, -9.81]";
      d.doc = "Gravitational acceleration.";
      return d;
    }(),
    option_detail::real("dt", kRun, "s", 0, true, option_detail::kInf, false, 0,
                        "contact duration / 50", "Time step.", "default_time_step()"),
    option_detail::integer("threads", 1, 4096, 0, "all cores", "OpenMP threads.",
                           "OpenMP's default"),
    option_detail::integer("parallel_min", 0, 2147483647, 2048, "2048",
                           "Scenes with fewer spheres run on one thread."),
    option_detail::integer("seed", 0, std::numeric_limits<std::uint64_t>::max(), 0, "0",
                           "Seed of the roughness draws."),
    option_detail::real("skin", kRun, "m", 0, true, option_detail::kInf, false, 0,
                        "0.2 mean diameter", "Neighbour-list skin.", "0.2 x the mean diameter"),
    option_detail::choice("tangential_history", kRun, choice_names(kHistoryRuleNames),
                          "\"rotate\"", "How the tangential displacement follows the contact."),
    option_detail::choice("slip_rule", kRun, choice_names(kSlipRuleNames), "\"frozen\"",
                          "What a slipping contact does."),
    option_detail::choice("adhesion", kRun, choice_names(kAdhesionLawNames), "\"jkr\"",
                          "Adhesive normal law of materials with a work_of_adhesion."),
    // Options::repulsive is true for "repulsive".
    option_detail::choice("hertz_force", kRun, ChoiceNames{"signed", "repulsive"}, "\"signed\"",
                          "Normal force of Hertzian materials."),
    option_detail::real("impact_speed", kRun, "m/s", 0, true, option_detail::kInf, false, 0,
                        "measured", "Impact speed for a Hertzian scene's contact duration.",
                        "the measured speed"),
    option_detail::real("max_overlap", kRun, "", 0, true, option_detail::kInf, false, 0.5, "0.5",
                        "Overlap (fraction of a radius) that stops a run as unstable."),
    option_detail::real("initial_overlap", kRun, "", 0, false, option_detail::kInf, false, 0.05,
                        "0.05", "Largest initial overlap accepted (fraction of a radius)."),
    option_detail::flag("allow_unstable_dt", "Run with a dt above the stability bound."),
    option_detail::flag("rebuild_every_step",
                        "Rebuild the neighbour list every step (a testing aid)."),
};

constexpr bool same_name(const char* a, std::string_view b) { return std::string_view(a) == b; }

// The declaration of `name` (a compile-time error, in a constant expression, for a name that is
// not declared).
constexpr const OptionDeclaration& option_declaration(std::string_view name) {
  for (const auto& d : kOptionTable)
    if (same_name(d.name, name)) return d;
  throw "no such option";  // not a constant expression: an unknown name does not compile
}

// The declaration of `name` at run time (InvalidArgument for a name that is not declared).
inline const OptionDeclaration& declaration_of(std::string_view name) {
  for (const auto& d : kOptionTable)
    if (same_name(d.name, name)) return d;
  throw InvalidArgument("no option named " + std::string(name));
}

// Whether `core_value` (in the core's units) is in the declared range (the bounds scaled to the
// core's units, as Python's conversion scales a value).
inline bool in_declared_range(const OptionDeclaration& d, double core_value) {
  const double v = core_value, lo = d.minimum * d.scale, hi = d.maximum * d.scale;
  if (!std::isfinite(v)) return false;
  return (d.exclusive_minimum ? v > lo : v >= lo) && (d.exclusive_maximum ? v < hi : v <= hi);
}

// The range as messages say it, in the core's units ("in (0, 1]", "a finite number > 0 (or 0
// for a linear material)"), and the check that throws InvalidArgument naming `prefix` + the
// option and the value (options.cpp).
std::string declared_range(const OptionDeclaration& d);
void check_declared(const OptionDeclaration& d, double core_value, const char* prefix = "");

}  // namespace tsubu
