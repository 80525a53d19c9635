// The option declarations (option_table.hpp) as Python data, and the core's checks of them: the
// Python layer builds its validation, the scene spec and the docs from option_table(), and
// tests/test_option_declarations.py compares the checks of both sides.
#include "bindings.hpp"

namespace tsubu_py {

namespace {

const char* kind_name(tsubu::OptionKind k) {
  switch (k) {
    case tsubu::OptionKind::Real: return "real";
    case tsubu::OptionKind::Integer: return "integer";
    case tsubu::OptionKind::Flag: return "flag";
    case tsubu::OptionKind::Choice: return "choice";
    case tsubu::OptionKind::Vector: return "vector";
  }
  return "";
}

py::dict declaration(const tsubu::OptionDeclaration& d) {
  py::dict out;
  out["name"] = d.name;
  py::list scopes;
  if (d.scopes & tsubu::kMaterial) scopes.append("material");
  if (d.scopes & tsubu::kPair) scopes.append("pair");
  if (d.scopes & tsubu::kRun) scopes.append("run");
  out["scopes"] = py::tuple(scopes);
  out["kind"] = kind_name(d.kind);
  out["unit"] = d.unit;
  const bool integer = d.kind == tsubu::OptionKind::Integer;
  auto bound = [&](double v, bool is_max) -> py::object {
    if (!std::isfinite(v)) return py::none();
    if (!integer) return py::float_(v);
    if (is_max) return py::int_(d.integer_maximum);
    return py::int_(static_cast<long long>(v));
  };
  out["minimum"] = bound(d.minimum, false);
  out["maximum"] = bound(d.maximum, true);
  out["exclusive_minimum"] = d.exclusive_minimum;
  out["exclusive_maximum"] = d.exclusive_maximum;
  out["zero_means"] = *d.zero_means ? py::object(py::str(d.zero_means)) : py::object(py::none());
  py::tuple choices(0);
  if (d.kind == tsubu::OptionKind::Choice) {
    py::list names;
    for (const char* n : d.choices)
      if (n) names.append(n);
    choices = py::tuple(names);
  }
  out["choices"] = choices;
  switch (d.kind) {
    case tsubu::OptionKind::Real: out["default"] = py::float_(d.default_value); break;
    case tsubu::OptionKind::Integer: out["default"] = py::int_(static_cast<long long>(d.default_value)); break;
    case tsubu::OptionKind::Flag: out["default"] = py::bool_(d.default_value != 0); break;
    case tsubu::OptionKind::Choice: out["default"] = choices[0]; break;
    case tsubu::OptionKind::Vector: out["default"] = py::none(); break;
  }
  out["default_text"] = d.default_text;
  out["doc"] = d.doc;
  out["scale"] = d.scale;
  out["core_unit"] = *d.core_unit ? d.core_unit : d.unit;
  out["checked_for"] = d.checked_for == tsubu::OptionFamily::Linear     ? "linear"
                       : d.checked_for == tsubu::OptionFamily::Hertzian ? "hertzian"
                                                                        : "any";
  out["needs_hertzian"] =
      *d.needs_hertzian ? py::object(py::str(d.needs_hertzian)) : py::object(py::none());
  out["law_choice"] = d.law_choice;
  out["details"] = d.details;
  return out;
}

}  // namespace

void register_options(py::module_& m) {
  m.def("option_table", [] {
          py::list out;
          for (const auto& d : tsubu::kOptionTable) out.append(declaration(d));
          return py::tuple(out);
        },
        "Every option's declaration (option_table.hpp), a dict each: name, scopes ('material', "
        "'pair', 'run'), kind ('real', 'integer', 'flag', 'choice', 'vector'), unit, minimum, "
        "maximum (None: unbounded), exclusive_minimum, exclusive_maximum, zero_means (what the "
        "core's 0 means, or None), choices, default, default_text, doc, scale (core value = scale "
        "x value), core_unit, checked_for (the materials its range is checked on: 'any', "
        "'linear', 'hertzian'), needs_hertzian (why a value > 0 needs a Hertzian material, or "
        "None), law_choice (a run choice the contact laws read) and details (the docstrings' "
        "paragraph, or '')");
  m.def("validate_material", &tsubu::validate_material, py::arg("material"),
        "The core's check of a Material (ValueError naming the field and the value)");
  m.def("validate_pair", &tsubu::validate_pair, py::arg("pair"),
        "The core's check of a PairParams (ValueError naming the field and the value)");
  m.def("validate_options",
        [](const tsubu::Simulation& s) { tsubu::validate_options(s.options()); }, py::arg("simulation"),
        "The core's check of a Simulation's run options, as a run starts (ValueError naming the "
        "option and the value)");
}

}  // namespace tsubu_py
