// What the register_*.cpp files share: numpy conversions and the one table of names for every
// enum the Python API takes as a string. The bindings convert and forward; python/tsubu checks
// arguments and names them, the core checks again for C++ callers.
#pragma once
#include <array>
#include <optional>
#include <string>
#include <utility>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "tsubu/option_table.hpp"
#include "tsubu/simulation.hpp"

namespace tsubu_py {

namespace py = pybind11;

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IntArray = py::array_t<int, py::array::c_style | py::array::forcecast>;

inline tsubu::Vec3 to_vec3(const std::array<double, 3>& a) { return tsubu::Vec3(a[0], a[1], a[2]); }
inline std::array<double, 3> from_vec3(const tsubu::Vec3& v) { return {v.x(), v.y(), v.z()}; }
inline const double* data_or_null(const std::optional<Array>& a) { return a ? a->data() : nullptr; }
inline Array new_n3(std::size_t n) { return Array({static_cast<py::ssize_t>(n), py::ssize_t(3)}); }
inline void check_n3(const Array& a, std::size_t n, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 3 || static_cast<std::size_t>(a.shape(0)) != n)
    throw py::value_error(std::string(name) + " must have shape (" + std::to_string(n) + ", 3)");
}

// ---- enums as strings: one table each ------------------------------------------------------
template <class E>
struct Choices;
// (the names are declared with the options, option_table.hpp)
template <>
struct Choices<tsubu::ScatterDistribution> {
  static constexpr const char* argument = "roughness_distribution";
  static constexpr const auto& names = tsubu::kScatterDistributionNames;
};
template <>
struct Choices<tsubu::ShadowRule> {
  static constexpr const char* argument = "shadow";
  static constexpr const auto& names = tsubu::kShadowRuleNames;
};
template <>
struct Choices<tsubu::HistoryRule> {
  static constexpr const char* argument = "tangential_history";
  static constexpr const auto& names = tsubu::kHistoryRuleNames;
};
template <>
struct Choices<tsubu::SlipRule> {
  static constexpr const char* argument = "slip_rule";
  static constexpr const auto& names = tsubu::kSlipRuleNames;
};
template <>
struct Choices<tsubu::AdhesionLaw> {
  static constexpr const char* argument = "adhesion";
  static constexpr const auto& names = tsubu::kAdhesionLawNames;
};

// "'a', 'b' or 'c'"
template <class E>
std::string listing() {
  const auto& names = Choices<E>::names;
  std::string s;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (k > 0) s += k + 1 == names.size() ? " or " : ", ";
    s += std::string("'") + names[k].first + "'";
  }
  return s;
}
template <class E>
E parse(const std::string& name) {
  for (const auto& [n, e] : Choices<E>::names)
    if (name == n) return e;
  throw py::value_error(std::string(Choices<E>::argument) + " must be " + listing<E>() + ", got '" +
                        name + "'");
}
template <class E>
const char* name_of(E e) {
  for (const auto& [n, v] : Choices<E>::names)
    if (v == e) return n;
  return "?";
}
template <class E>
py::tuple names() {
  py::list l;
  for (const auto& [n, e] : Choices<E>::names) l.append(n);
  return py::tuple(l);
}

void register_materials(py::module_& m);
void register_options(py::module_& m);
void register_simulation(py::class_<tsubu::Simulation>& cls);
void register_state(py::class_<tsubu::Simulation>& cls);

}  // namespace tsubu_py
