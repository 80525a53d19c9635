// tsubu::Simulation's state, in id order, as numpy arrays; energy, contacts and diagnostics.
#include "bindings.hpp"

namespace tsubu_py {

namespace {

using Sim = tsubu::Simulation;
using namespace pybind11::literals;

// A per-sphere (N, 3) quantity, read through one of Simulation's get_* functions.
template <void (Sim::*get)(double*) const>
Array n3(const Sim& s) {
  Array a = new_n3(s.size());
  (s.*get)(a.mutable_data());
  return a;
}
template <class T, void (Sim::*get)(T*) const>
py::array_t<T> n1(const Sim& s) {
  py::array_t<T> a(static_cast<py::ssize_t>(s.size()));
  (s.*get)(a.mutable_data());
  return a;
}

py::dict contacts_dict(const Sim& s) {
  const auto list = s.contacts();
  const std::size_t m = list.size();
  py::array_t<std::int64_t> i(m), j(m);
  py::array_t<int> wall(m);
  Array overlap(m);
  Array force = new_n3(m), torque = new_n3(m), xi = new_n3(m);
  auto pi = i.mutable_unchecked<1>();
  auto pj = j.mutable_unchecked<1>();
  auto pw = wall.mutable_unchecked<1>();
  auto po = overlap.mutable_unchecked<1>();
  auto pf = force.mutable_unchecked<2>();
  auto pt = torque.mutable_unchecked<2>();
  auto px = xi.mutable_unchecked<2>();
  for (std::size_t k = 0; k < m; ++k) {
    const auto& c = list[k];
    pi(k) = c.i;
    pj(k) = c.j;
    pw(k) = c.wall;
    po(k) = c.overlap;
    for (int d = 0; d < 3; ++d) {
      pf(k, d) = c.force[d];
      pt(k, d) = c.torque_i[d];
      px(k, d) = c.tangential_displacement[d];
    }
  }
  return py::dict("i"_a = i, "j"_a = j, "wall"_a = wall, "overlap"_a = overlap, "force"_a = force,
                  "torque_i"_a = torque, "tangential_displacement"_a = xi);
}

// numpy (N, 3) input, checked against the number of spheres, to one of the set_* functions.
template <void (Sim::*set)(const double*)>
void set_n3(Sim& s, const Array& a, const char* name) {
  check_n3(a, s.size(), name);
  (s.*set)(a.data());
}

}  // namespace

void register_state(py::class_<Sim>& cls) {
  cls.def_property_readonly("size", &Sim::size)
      .def("positions", &n3<&Sim::get_positions>)
      .def("velocities", &n3<&Sim::get_velocities>)
      .def("angular_velocities", &n3<&Sim::get_angular_velocities>)
      .def("forces", &n3<&Sim::get_forces>)
      .def("torques", &n3<&Sim::get_torques>)
      .def("radii", &n1<double, &Sim::get_radii>)
      .def("masses", &n1<double, &Sim::get_masses>)
      .def("materials", &n1<int, &Sim::get_materials>)
      .def("set_positions", [](Sim& s, const Array& a) { set_n3<&Sim::set_positions>(s, a, "positions"); })
      .def("set_velocities",
           [](Sim& s, const Array& a) { set_n3<&Sim::set_velocities>(s, a, "velocities"); })
      .def("set_angular_velocities",
           [](Sim& s, const Array& a) {
             set_n3<&Sim::set_angular_velocities>(s, a, "angular_velocities");
           })
      .def(
          "energy",
          [](const Sim& s, bool at_positions) {
            const tsubu::Energy e = at_positions ? s.energy_now() : s.energy();
            return py::dict("translational"_a = e.translational, "rotational"_a = e.rotational,
                            "kinetic"_a = e.kinetic(), "gravitational"_a = e.gravitational,
                            "elastic"_a = e.elastic, "total"_a = e.total(),
                            "dissipated"_a = e.dissipated, "step_correction"_a = e.step_correction);
          },
          "at_positions"_a = false)
      .def("contacts", &contacts_dict)
      .def("rebuild_neighbors", &Sim::rebuild_neighbors)
      .def("neighbor_pairs",
           [](const Sim& s) {
             const auto pairs = s.neighbor_pairs();
             py::array_t<std::int64_t> a({static_cast<py::ssize_t>(pairs.size()), py::ssize_t(2)});
             auto p = a.mutable_unchecked<2>();
             for (std::size_t k = 0; k < pairs.size(); ++k) {
               p(k, 0) = pairs[k][0];
               p(k, 1) = pairs[k][1];
             }
             return a;
           })
      .def_property_readonly("rebuild_count", &Sim::rebuild_count)
      .def_property_readonly("near_refresh_count", &Sim::near_refresh_count)
      .def_property_readonly("fused_step_count", &Sim::fused_step_count)
      .def("phase_seconds",
           [](const Sim& s) {
             py::dict d;
             for (int p = 0; p < int(tsubu::Phase::Count); ++p)
               d[tsubu::phase_name(tsubu::Phase(p))] = s.phase_seconds()[p];
             return d;
           })
      .def("memory_bytes",
           [](const Sim& s) {
             py::dict d;
             for (const auto& [name, bytes] : s.memory_bytes()) d[py::str(name)] = bytes;
             return d;
           })
      .def("skin", &Sim::skin);
}

}  // namespace tsubu_py
