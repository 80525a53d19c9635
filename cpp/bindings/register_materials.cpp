// tsubu::Material and tsubu::PairParams as Python classes. Each field is bound once, here, and
// listed in the class's `fields` attribute, which the Python layer reads instead of naming them
// again.
#include "bindings.hpp"

namespace tsubu_py {

namespace {

// The fields a material and a pair share (the laws' parameter sets), on class `cls`.
template <class C>
void law_fields(py::class_<C>& cls, py::list& fields) {
  auto number = [&](const char* name, auto member, const char* doc) {
    cls.def_readwrite(name, member, doc);
    fields.append(name);
  };
  number("kn", &C::kn, "normal stiffness [N/m]");
  number("kt", &C::kt, "tangential stiffness [N/m]");
  number("restitution", &C::restitution, "normal coefficient of restitution, (0, 1]");
  number("friction", &C::friction, "Coulomb coefficient mu");
  number("rolling_friction", &C::rolling_friction, "rolling friction coefficient mu_r");
  number("tangential_damping", &C::tangential_damping, "eta_t / eta_n");
  number("roughness", &C::roughness, "standard deviation of the scatter angle [rad]");
  cls.def_property(
      "roughness_distribution", [](const C& c) { return name_of(c.roughness_distribution); },
      [](C& c, const std::string& v) { c.roughness_distribution = parse<tsubu::ScatterDistribution>(v); });
  fields.append("roughness_distribution");
  cls.def_property(
      "shadow", [](const C& c) { return name_of(c.shadow); },
      [](C& c, const std::string& v) { c.shadow = parse<tsubu::ShadowRule>(v); });
  fields.append("shadow");
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
  material.def_readwrite("density", &tsubu::Material::density, "kg/m^3");
  material_fields.append("density");
  material.def_readwrite("youngs_modulus", &tsubu::Material::youngs_modulus,
                         "Young's modulus E [Pa]; 0: a linear (kn, kt) material");
  material_fields.append("youngs_modulus");
  material.def_readwrite("poisson_ratio", &tsubu::Material::poisson_ratio, "Poisson's ratio nu");
  material_fields.append("poisson_ratio");
  law_fields(material, material_fields);
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
  pair.def_readwrite("effective_modulus", &tsubu::PairParams::effective_modulus,
                     "Hertz's E* [Pa]; 0: a linear pair");
  pair_fields.append("effective_modulus");
  pair.def_readwrite("effective_shear_modulus", &tsubu::PairParams::effective_shear_modulus,
                     "Mindlin's G* [Pa]");
  pair_fields.append("effective_shear_modulus");
  law_fields(pair, pair_fields);
  pair.attr("fields") = py::tuple(pair_fields);
}

}  // namespace tsubu_py
