// tsubu::Material and tsubu::PairParams as Python classes. Each field is bound from its
// declaration (option_table.hpp), through the laws' parameter sets (contact/parameters.hpp), and
// listed in the class's `fields` attribute, which the Python layer reads instead of naming them.
#include <deque>
#include <type_traits>

#include "bindings.hpp"

namespace tsubu_py {

namespace {

// A field's doc: its declaration's (option_table.hpp), with the core's unit and range.
const char* field_doc(const tsubu::OptionDeclaration& d) {
  static std::deque<std::string> docs;  // pybind11 keeps the pointer
  const std::string unit = *d.core_unit ? "" : d.unit;  // (declared_range names a core unit)
  std::string doc = d.doc;
  if (!unit.empty()) doc += " [" + unit + "]";
  if (d.kind == tsubu::OptionKind::Real) doc += " Must be " + tsubu::declared_range(d) + ".";
  if (d.kind == tsubu::OptionKind::Choice) doc += std::string(" Default \"") + d.choices[0] + "\".";
  docs.push_back(doc);
  return docs.back().c_str();
}

// Every field of C (tsubu::Material or tsubu::PairParams), in the order of the declarations
// (tsubu::for_each_declared_field), on class `cls` and in `fields`: a number, or a choice as its
// name.
template <class C>
void declared_fields(py::class_<C>& cls, py::list& fields) {
  tsubu::for_each_declared_field<C>([&](const tsubu::OptionDeclaration& d, auto member) {
    using T = tsubu::member_type<decltype(member)>;
    if constexpr (std::is_enum_v<T>) {
      const tsubu::OptionDeclaration* decl = &d;
      cls.def_property(
          d.name, [member, decl](const C& c) { return choice_name(*decl, static_cast<int>(c.*member)); },
          [member, decl](C& c, const std::string& v) { c.*member = static_cast<T>(parse_choice(*decl, v)); },
          field_doc(d));
      bound_choice(d);
    } else {
      cls.def_readwrite(d.name, member, field_doc(d));
    }
    fields.append(d.name);
  });
}

// C(**fields) and repr. The constructor default-constructs and assigns each keyword through the
// bound property (so enum names go through the one table), never aggregate-initialises: the core
// may move fields between its laws' parameter bases.
template <class C>
void keywords_and_repr(py::class_<C>& cls, const char* name) {
  const std::string n = name;
  cls.def(py::init([n](const py::kwargs& kw) {
            py::object obj = py::cast(C());
            const py::object fields = obj.attr("fields");
            for (const auto& item : kw) {
              const py::handle key = item.first, value = item.second;
              if (!fields.contains(key))
                throw py::type_error(n + "() got an unexpected keyword argument '" +
                                     std::string(py::str(key)) + "'");
              try {
                py::setattr(obj, key, value);
              } catch (py::error_already_set& e) {
                if (!e.matches(PyExc_TypeError)) throw;
                throw py::type_error(n + "() argument '" + std::string(py::str(key)) +
                                     "' has the wrong type, got " +
                                     std::string(py::repr(value)));
              }
            }
            return obj.cast<C>();
          }),
          "Keywords: any of `fields`; the others keep their defaults");
  cls.def("__repr__", [n](const py::object& self) {
    std::string s = n + "(";
    for (const auto& f : self.attr("fields")) {
      if (s.back() != '(') s += ", ";
      s += std::string(py::str(f)) + "=" + std::string(py::repr(self.attr(f)));
    }
    return s + ")";
  });
}

}  // namespace

void register_materials(py::module_& m) {
  py::class_<tsubu::Material> material(m, "Material", "One material (SI units, roughness in radians)");
  keywords_and_repr(material, "Material");
  py::list material_fields;
  declared_fields(material, material_fields);
  material.attr("fields") = py::tuple(material_fields);
  m.def("hertz_restitution", &tsubu::HertzDamping::restitution, py::arg("factor"), py::arg("clipped"),
        "The restitution of a Hertzian impact with dashpot eta_n = factor sqrt(S_n m*), the normal "
        "force clipped at zero or not (integrated, dimensionless)");
  m.def("hertz_damping_factor", [](double e, bool clipped) {
          return clipped ? tsubu::HertzDamping::repulsive_factor(e) : tsubu::HertzDamping::signed_factor(e);
        }, py::arg("restitution"), py::arg("clipped"),
        "The factor f of eta_n = f sqrt(S_n m*) that gives restitution e: 2 sqrt(5/6) |beta|, or, "
        "for a force clipped at zero, the value found by bisection on hertz_restitution");

  py::class_<tsubu::PairParams> pair(m, "PairParams",
                                     "The contact parameters of one pair of materials");
  keywords_and_repr(pair, "PairParams");
  py::list pair_fields;
  declared_fields(pair, pair_fields);
  pair.attr("fields") = py::tuple(pair_fields);
}

}  // namespace tsubu_py
