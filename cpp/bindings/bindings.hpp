// What the register_*.cpp files share: numpy conversions and the conversions of every option the
// Python API takes as a string, from its declaration's names. The bindings convert and forward;
// python/tsubu checks arguments and names them, the core checks again for C++ callers.
#pragma once
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

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

// ---- choices as strings: the names of each Choice's declaration ----------------------------
// The core keeps a choice as the index of its name in its declaration (option_table.hpp): an
// enum with those indices as values, or an int (a law choice).

// "'a', 'b' or 'c'"
inline std::string listing(const tsubu::OptionDeclaration& d) {
  const std::size_t n = tsubu::choice_count(d.choices);
  std::string s;
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0) s += k + 1 == n ? " or " : ", ";
    s += std::string("'") + d.choices[k] + "'";
  }
  return s;
}
// The index of `name` among d's choices (ValueError naming the option, its choices and `name`).
inline int parse_choice(const tsubu::OptionDeclaration& d, const std::string& name) {
  for (std::size_t k = 0; k < tsubu::choice_count(d.choices); ++k)
    if (name == d.choices[k]) return static_cast<int>(k);
  throw py::value_error(std::string(d.name) + " must be " + listing(d) + ", got '" + name + "'");
}
inline const char* choice_name(const tsubu::OptionDeclaration& d, int k) {
  return k >= 0 && static_cast<std::size_t>(k) < tsubu::choice_count(d.choices) ? d.choices[k] : "?";
}
// The choices the bindings parse, in the table's order: what _core.choices lists (every Choice
// bound as a string property registers itself here as it is bound).
void bound_choice(const tsubu::OptionDeclaration& d);
py::dict bound_choices();

void register_materials(py::module_& m);
void register_options(py::module_& m);
void register_simulation(py::class_<tsubu::Simulation>& cls);
void register_state(py::class_<tsubu::Simulation>& cls);
void register_boundaries(py::class_<tsubu::Simulation>& cls);
void register_periodic(py::class_<tsubu::Simulation>& cls);

}  // namespace tsubu_py
