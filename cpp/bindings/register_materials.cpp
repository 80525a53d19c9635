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

}  // namespace

void register_materials(py::module_& m) {
  py::class_<tsubu::Material> material(m, "Material", "One material (SI units, roughness in radians)");
  material.def(py::init<>());
  py::list material_fields;
  material.def_readwrite("density", &tsubu::Material::density, "kg/m^3");
  material_fields.append("density");
  law_fields(material, material_fields);
  material.attr("fields") = py::tuple(material_fields);

  py::class_<tsubu::PairParams> pair(m, "PairParams",
                                     "The contact parameters of one pair of materials");
  pair.def(py::init<>());
  py::list pair_fields;
  law_fields(pair, pair_fields);
  pair.attr("fields") = py::tuple(pair_fields);
}

}  // namespace tsubu_py
