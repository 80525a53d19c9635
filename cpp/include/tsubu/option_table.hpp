// Every option a user sets, declared once: the material fields, the per-pair overrides and the
// run options, each with its name, unit, range, default, a one-line doc and the paragraph the
// Python docstrings give. The C++ checks (options.cpp), the defaults of a Material
// (material.hpp), the bindings, the checkpoints, the Python API (python/tsubu/_options.py reads
// this table through _core.option_table(): tsubu.Material's fields and Simulation's keyword
// arguments, their checks and docstrings), the scene format's spec, JSON Schema and reference
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

#include "types.hpp"

namespace tsubu {

// Where an option is set (a bit mask): a Material field, a per-pair override
// (Simulation::set_pair_parameters), or an option of the run (Options, Simulation's constructor).
enum OptionScope : unsigned { kMaterial = 1, kPair = 2, kRun = 4 };
// What an option's value is.
enum class OptionKind { Real, Integer, Flag, Choice, Vector };

// A Choice's names, the first the default (unused entries are nullptr). The core stores a
// choice as its index here: the enum of a choice the core keeps as one (HistoryRule,
// ScatterDistribution, ...) has these indices as its values, in this order.
constexpr std::size_t kMaxChoices = 4;
using ChoiceNames = std::array<const char*, kMaxChoices>;

constexpr std::size_t choice_count(const ChoiceNames& names) {
  std::size_t n = 0;
  while (n < kMaxChoices && names[n]) ++n;
  return n;
}

// Which materials (and pairs) an option's range is checked on: every one, or only the linear
// ones (kn: a Hertzian material's is unused) or only the Hertzian ones (poisson_ratio). A
// material is Hertzian when it has a youngs_modulus, a pair when it has an effective_modulus.
enum class OptionFamily { Any, Linear, Hertzian };

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
  OptionFamily checked_for = OptionFamily::Any;  // a material's or pair's option
  // Non-empty: a value > 0 needs a Hertzian material or pair (why, for the message: a law
  // offered on Hertz's law only); its range is checked on every material.
  const char* needs_hertzian = "";
  // A run Choice the contact laws' selection reads (contact/selection.hpp): the core keeps it in
  // Options::law_choices (law_choice_slot(name)), and the bindings, the checks and the
  // checkpoints handle it from this declaration alone.
  bool law_choice = false;
  // The paragraph the Python docstrings give (Material's and Simulation's Parameters entries,
  // numpy-style RST, one line: Python wraps it); empty: the doc, unit and default.
  const char* details = "";
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
constexpr OptionDeclaration checked_for(OptionFamily family, OptionDeclaration d) {
  d.checked_for = family;
  return d;
}
constexpr OptionDeclaration needs_hertzian(const char* why, OptionDeclaration d) {
  d.needs_hertzian = why;
  return d;
}
constexpr OptionDeclaration law_choice(OptionDeclaration d) {
  d.law_choice = true;
  return d;
}
constexpr OptionDeclaration details(const char* text, OptionDeclaration d) {
  d.details = text;
  return d;
}
}  // namespace option_detail

// The table. Order: the materials' fields, the pairs' own, the run's (in the order of the
// Python constructor's arguments, tsubu.Simulation: a new run option goes where its position
// in that signature should be).
namespace option_detail {
inline constexpr OptionDeclaration kTable[] = {
    // ---- materials (and, where kLaw, pair overrides) ----
    details("Mass density [kg/m^3], > 0. Default 2500 (glass). Unused for walls.",
            real("density", kMaterial, "kg/m^3", 0, true, kInf, false, 2500, "2500",
                 "Mass density.")),
    details("Normal spring stiffness [N/m], > 0 (linear Kelvin-Voigt law, eq. 1.6). Default 1e3 "
            "for a linear material; None (unused) for a Hertzian one. Two materials mix as the "
            "harmonic mean ``2 a b / (a + b)`` (two half-springs in series; equal materials keep "
            "their own value).",
            checked_for(OptionFamily::Linear,
                        real("kn", kLaw, "N/m", 0, true, kInf, false, 1e3,
                             "1e3 for a linear material",
                             "Normal spring stiffness of the linear (Kelvin-Voigt) law."))),
    details("Tangential spring stiffness [N/m], >= 0. Default ``2/7 kn``, which gives the "
            "tangential oscillation of a rolling sphere the frequency of the normal one. None for "
            "a Hertzian material. Two materials mix as kn does.",
            checked_for(OptionFamily::Linear,
                        real("kt", kLaw, "N/m", 0, false, kInf, false, 2.0 / 7.0 * 1e3, "2/7 kn",
                             "Tangential spring stiffness of the linear law."))),
    details("Young's modulus E [Pa], > 0: makes the material Hertzian. Default None (linear). Two "
            "Hertzian materials mix as ``1/E* = (1 - nu_a^2)/E_a + (1 - nu_b^2)/E_b`` and ``1/G* "
            "= (2 - nu_a)/G_a + (2 - nu_b)/G_b``, ``G = E / (2 (1 + nu))`` (a plane wall: the "
            "wall material's E and nu, with ``R* = r`` and ``m* = m`` of the sphere; a rigid wall "
            "is a wall material with a much larger E).",
            real("youngs_modulus", kMaterial, "Pa", 0, true, kInf, false, 0, "none (linear)",
                 "Young's modulus E: makes the material Hertz-Mindlin (then kn, kt must not be "
                 "given).",
                 "a linear material")),
    details("Poisson's ratio nu in (-1, 0.5] of a Hertzian material. Default 0.3 when "
            "``youngs_modulus`` is given; giving it without ``youngs_modulus`` is a ValueError.",
            checked_for(OptionFamily::Hertzian,
                        real("poisson_ratio", kMaterial, "", -1, true, 0.5, false, 0.3,
                             "0.3 with youngs_modulus", "Poisson's ratio of a Hertzian material."))),
    details("Normal coefficient of restitution e in (0, 1]. Default 0.5. Linear law: the normal "
            "dashpot is ``eta_n = -2 ln(e) sqrt(m_eff kn / (pi^2 + ln^2 e))`` (eq. B.9) with the "
            "reduced mass ``m_eff = m_i m_j / (m_i + m_j)`` of the pair (walls: ``m_i``), so "
            "every contact rebounds with e. The normal force is not clipped at zero (B.9 assumes "
            "it). Hertzian: ``eta_n = 2 sqrt(5/6) |beta| sqrt(S_n m*)``, ``S_n = 2 E* sqrt(R* "
            "delta)``, ``beta = ln e / sqrt(ln^2 e + pi^2)`` (or, with "
            "``Simulation(hertz_force=\"repulsive\")``, the dashpot that gives e with a force "
            "clipped at zero). Two materials mix as the geometric mean.",
            real("restitution", kLaw, "", 0, true, 1, false, 0.5, "0.5",
                 "Normal coefficient of restitution.")),
    details("Coulomb friction coefficient mu >= 0 (eqs. 1.17-1.18). Default 0.5. 0 makes "
            "contacts frictionless: the run then uses a specialisation with no tangential code or "
            "history. Two materials mix as the geometric mean.",
            real("friction", kLaw, "", 0, false, kInf, false, 0.5, "0.5",
                 "Coulomb friction coefficient (0: frictionless).")),
    details("Rolling friction coefficient mu_r >= 0 (eq. 1.20), dimensionless. Default 0. Two "
            "materials mix as the geometric mean.",
            real("rolling_friction", kLaw, "", 0, false, kInf, false, 0, "0",
                 "Rolling friction coefficient.")),
    details("Tangential dashpot as a fraction of the normal one, ``eta_t = tangential_damping * "
            "eta_n`` (eq. 1.11), >= 0. Default 0, as in the shared reference scene and LAMMPS's "
            "``gran/hooke/history`` with ``gamma_t = 0`` (LAMMPS's NULL default is 0.5). Two "
            "materials mix as the geometric mean.",
            real("tangential_damping", kLaw, "", 0, false, kInf, false, 0, "0",
                 "Tangential dashpot as a fraction of the normal one.")),
    details("Standard deviation sigma of the roughness scatter angle, in DEGREES, in [0, 90): at "
            "first touch the contact normal is tilted by a random angle dG (docs/roughness.md). 0 "
            "(default): smooth, and the run uses a specialisation without roughness code. Two "
            "materials combine as sqrt(sigma_a^2 + sigma_b^2).",
            degrees(real("roughness", kLaw, "degrees", 0, false, 90, true, 0, "0",
                         "Standard deviation of the roughness scatter angle "
                         "(docs/roughness.md)."))),
    details("Work of adhesion w [J/m^2] >= 0 of two surfaces of this material (``2 gamma``, "
            "gamma its surface energy). Default 0 (no adhesion). Only for a Hertzian material: "
            "w > 0 makes the scene adhesive, with the normal law chosen by "
            "``Simulation(adhesion=...)``: JKR (default; the contact is made at zero overlap and "
            "holds to the negative overlap ``delta_c = -(3/4) (pi^2 w^2 R* / E*^2)^(1/3)``, "
            "pull-off force ``(3/2) pi w R*``) or DMT (Hertz's force less ``2 pi w R*``, "
            "pull-off ``2 pi w R*``), with the Hertzian dashpot and Mindlin's spring "
            "(docs/physics.md). Two materials mix as ``sqrt(w_a w_b)`` (Dupre's ``w_ab = gamma_a "
            "+ gamma_b - gamma_ab`` with Berthelot's rule for the interface). Roughness, "
            "``hertz_force=\"repulsive\"`` and ``slip_rule=\"truncate\"`` are not offered with "
            "adhesion.",
            needs_hertzian("adhesion is offered on Hertz's law",
                           real("work_of_adhesion", kLaw, "J/m^2", 0, false, kInf, false, 0, "0",
                                "Work of adhesion of two surfaces (2 x the surface energy) of a "
                                "Hertzian material: JKR or DMT (docs/physics.md)."))),
    details("Distribution of dG: zero-mean normal with standard deviation sigma, truncated to "
            "``abs(dG) < 90`` degrees (default), or uniform on [-sqrt(3) sigma, sqrt(3) sigma] "
            "(same standard deviation).",
            choice("roughness_distribution", kLaw, ChoiceNames{"normal", "uniform"},
                   "\"normal\"", "Distribution of the roughness tilt.")),
    details("Shadow effect at walls (Sommerfeld & Huber 1999): \"reject\" (default) redraws tilts "
            "the sphere could not meet (dG < -gamma in the plane of incidence); \"weighted\" also "
            "weights the accepted tilts by sin(gamma + dG); \"none\" keeps every draw.",
            choice("shadow", kLaw, ChoiceNames{"reject", "weighted", "none"}, "\"reject\"",
                   "Shadow effect at walls (docs/roughness.md).")),
    // ---- pairs only ----
    real("effective_modulus", kPair, "Pa", 0, true, kInf, false, 0, "mixed",
         "E* of a pair of Hertzian materials.", "a linear pair"),
    checked_for(OptionFamily::Hertzian,
                real("effective_shear_modulus", kPair, "Pa", 0, false, kInf, false, 0, "mixed",
                     "G* of a pair of Hertzian materials.")),
    // ---- the run ----
    details("Gravitational acceleration [m/s^2], shape (3,). Default ``(0, 0, -9.81)``.",
            [] {
              OptionDeclaration d{"gravity", kRun, OptionKind::Vector, "m/s^2"};
              d.default_text = "[0, 0, -9.81]";
              d.doc = "Gravitational acceleration.";
              return d;
            }()),
    details("Time step [s]. None: ``default_time_step()`` = t_c / 50, with t_c = pi/alpha (B.3, "
            "B.5) the shortest contact duration of the scene, evaluated when a run starts. A dt "
            "above ``critical_time_step()`` (2.31) is refused unless ``allow_unstable_dt`` is "
            "True.",
            real("dt", kRun, "s", 0, true, kInf, false, 0, "contact duration / 50", "Time step.",
                 "default_time_step()")),
    details("OpenMP threads, 1 to 4096. None: OpenMP's default (all cores). Results are "
            "bit-identical for any count. More than twice the threads the machine gives the "
            "process (``os.sched_getaffinity``), and more than 4, issue a "
            ":class:`PerformanceWarning`: each thread beyond the cores waits at every barrier of "
            "every step (on 2 cores, 64 threads ran 9x slower than 1, and 4096 threads 2600x).",
            integer("threads", 1, 4096, 0, "all cores", "OpenMP threads.", "OpenMP's default")),
    details("Seed of the roughness draws (0 <= seed < 2^64). Default 0. A run is reproducible "
            "for a given seed whatever the thread count; another seed gives another run.",
            integer("seed", 0, std::numeric_limits<std::uint64_t>::max(), 0, "0",
                    "Seed of the roughness draws.")),
    details("Neighbour-list skin [m]. None: 0.2 x the mean diameter. The list is rebuilt when a "
            "particle has moved more than skin/2 (or a moving wall could reach a new particle). A "
            "run whose skin is beyond the largest diameter and whose list holds more than 64 pairs "
            "per sphere (and over 100,000 in all) issues a :class:`PerformanceWarning`.",
            real("skin", kRun, "m", 0, true, kInf, false, 0, "0.2 mean diameter",
                 "Neighbour-list skin.", "0.2 x the mean diameter")),
    details("How the stored tangential displacement follows the contact. \"rotate\" (default): "
            "kept as a vector, rotated into the current tangent plane each step with its length "
            "preserved, then incremented by v_t dt (as LAMMPS, LIGGGHTS). \"literal\": the notes' "
            "eq. (1.14), which re-aims the whole accumulated length along the current v_t; "
            "offered for comparison (docs/physics.md).",
            choice("tangential_history", kRun, ChoiceNames{"rotate", "literal"}, "\"rotate\"",
                   "How the tangential displacement follows the contact.")),
    details("What a slipping contact does. \"frozen\" (default): the notes' (1.17)-(1.18), force "
            "``mu abs(f_n)`` against the slip velocity, stored displacement kept. \"truncate\": "
            "LAMMPS's gran/hooke/history and the shared reference scene's: the spring force is "
            "scaled to ``mu abs(f_n)`` in its own direction and the displacement truncated to "
            "match (needs tangential_history=\"rotate\"); use it to compare with those codes "
            "digit for digit.",
            choice("slip_rule", kRun, ChoiceNames{"frozen", "truncate"}, "\"frozen\"",
                   "What a slipping contact does.")),
    // Options::repulsive is true for "repulsive".
    details("The normal force of Hertzian materials. \"signed\" (default): the dashpot of the "
            "beta form (EDEM, LIGGGHTS, DEM-Engine, LAMMPS's tsuji damping), which gives the "
            "requested restitution at every impact speed and lets the force pull at the end of "
            "an impact. \"repulsive\": the force is clipped at zero (it never pulls) and the "
            "dashpot is raised so that the restitution is still the one requested "
            "(docs/physics.md).",
            choice("hertz_force", kRun, ChoiceNames{"signed", "repulsive"}, "\"signed\"",
                   "Normal force of Hertzian materials.")),
    details("The adhesive normal law of a scene whose materials have a ``work_of_adhesion`` > 0 "
            "(unused otherwise). \"jkr\" (default): Johnson-Kendall-Roberts, a neck that holds "
            "the contact to a negative overlap; \"dmt\": Derjaguin-Muller-Toporov, Hertz's force "
            "less a constant pull while in contact (docs/physics.md). Adhesion is not offered "
            "with roughness, ``hertz_force=\"repulsive\"``, ``slip_rule=\"truncate\"`` or "
            "``tangential_history=\"literal\"`` (the first run raises ValueError).",
            law_choice(choice("adhesion", kRun, ChoiceNames{"jkr", "dmt"}, "\"jkr\"",
                              "Adhesive normal law of materials with a work_of_adhesion."))),
    details("The normal impact speed [m/s] at which a Hertzian scene's contact duration, default "
            "dt and stability bound are evaluated (Hertzian contacts stiffen with speed). None: "
            "twice the largest sphere speed (two spheres meeting head on), at least 1 m/s, "
            "measured when asked before the first run and fixed by the first run (until spheres "
            "are added), so that the default dt stays the same from one run to the next.",
            real("impact_speed", kRun, "m/s", 0, true, kInf, false, 0, "measured",
                 "Impact speed for a Hertzian scene's contact duration.", "the measured speed")),
    details("A run stops with :class:`InstabilityError` when an overlap exceeds this fraction of "
            "the smaller radius, > 0. Default 0.5.",
            real("max_overlap", kRun, "", 0, true, kInf, false, 0.5, "0.5",
                 "Overlap (fraction of a radius) that stops a run as unstable.")),
    details("The first run refuses (ValueError) initial overlaps larger than this fraction of the "
            "smaller radius, >= 0. Default 0.05. Later runs refuse those that spheres added or "
            "moved (:meth:`add_spheres`, :attr:`positions`), or walls added, since the last run "
            "made (an overlap the change did not deepen, as when a pack is moved as a whole, stays "
            "accepted); the spheres of inserters (:meth:`add_inserter`) are placed clear by them.",
            real("initial_overlap", kRun, "", 0, false, kInf, false, 0.05, "0.05",
                 "Largest initial overlap accepted (fraction of a radius).")),
    details("Run even if dt exceeds the stability bound (the instability check still applies). "
            "Default False.",
            flag("allow_unstable_dt", "Run with a dt above the stability bound.")),
    details("Rebuild the neighbour list every step (a testing aid; results are identical). "
            "Default False.",
            flag("rebuild_every_step", "Rebuild the neighbour list every step (a testing aid).")),
    details("Scenes with fewer spheres than this run on one thread, whatever ``threads`` says: "
            "there a parallel region costs more than it saves (and on a machine whose cores are "
            "busy with other work, waiting at its barriers can cost far more). Default 2048; 0 "
            "always uses ``threads``.",
            integer("parallel_min", 0, 2147483647, 2048, "2048",
                    "Scenes with fewer spheres run on one thread.")),
};
}  // namespace option_detail
inline constexpr const auto& kOptionTable = option_detail::kTable;

constexpr bool same_name(const char* a, std::string_view b) { return std::string_view(a) == b; }

// The declaration of `name` (a compile-time error, in a constant expression, for a name that is
// not declared).
constexpr const OptionDeclaration& option_declaration(std::string_view name) {
  for (const auto& d : kOptionTable)
    if (same_name(d.name, name)) return d;
  throw "no such option";  // not a constant expression: an unknown name does not compile
}

// The run options the contact laws read (law_choice): how many, and the slot of `name` in
// Options::law_choices (a compile-time error, in a constant expression, for another name).
constexpr std::size_t law_choice_count() {
  std::size_t n = 0;
  for (const auto& d : kOptionTable) n += d.law_choice;
  return n;
}
inline constexpr std::size_t kLawChoiceCount = law_choice_count();
constexpr std::size_t law_choice_slot(std::string_view name) {
  std::size_t k = 0;
  for (const auto& d : kOptionTable) {
    if (d.law_choice && same_name(d.name, name)) return k;
    k += d.law_choice;
  }
  throw "no such law choice";  // not a constant expression: an unknown name does not compile
}

// f(declaration, slot) for each law choice, in the table's order.
template <class F>
void for_each_law_choice(F&& f) {
  std::size_t slot = 0;
  for (const auto& d : kOptionTable)
    if (d.law_choice) f(d, slot++);
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
