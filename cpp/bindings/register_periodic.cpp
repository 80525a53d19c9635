// A periodic box and Lees–Edwards shear (tsubu/domain.hpp): converts and forwards.
#include "bindings.hpp"

namespace tsubu_py {

void register_periodic(py::class_<tsubu::Simulation>& cls) {
  using namespace pybind11::literals;
  using Sim = tsubu::Simulation;
  cls.def(
         "set_box",
         [](Sim& s, std::array<double, 3> lower, std::array<double, 3> upper, std::array<bool, 3> periodic) {
           s.set_box(to_vec3(lower), to_vec3(upper), periodic);
         },
         "lower"_a, "upper"_a, "periodic"_a)
      .def("set_shear", &Sim::set_shear, "rate"_a, "flow"_a, "gradient"_a)
      .def("set_pressure", &Sim::set_pressure, "pressure"_a, "axis"_a, "gain"_a, "max_rate"_a)
      .def("clear_pressure", &Sim::clear_pressure)
      .def("box_pressure", &Sim::box_pressure, "axis"_a)
      .def("box",
           [](const Sim& s) {
             const tsubu::Domain& d = s.domain();
             const tsubu::Vec3 lo = d.lower(), hi = d.upper();
             return py::dict("lower"_a = std::array<double, 3>{lo[0], lo[1], lo[2]},
                             "upper"_a = std::array<double, 3>{hi[0], hi[1], hi[2]},
                             "periodic"_a = std::array<bool, 3>{d.periodic(0), d.periodic(1), d.periodic(2)},
                             "sheared"_a = d.sheared(), "shear_rate"_a = d.shear_rate(),
                             "shear_offset"_a = d.shear_offset(), "flow"_a = d.flow(),
                             "gradient"_a = d.gradient(), "pressure_on"_a = d.servo().on,
                             "pressure"_a = d.servo().pressure, "pressure_axis"_a = d.servo().axis,
                             "pressure_gain"_a = d.servo().gain, "max_strain_rate"_a = d.servo().max_rate);
           })
      .def("images",
           [](const Sim& s) {
             py::array_t<std::int64_t> out({static_cast<py::ssize_t>(s.size()), py::ssize_t(3)});
             s.get_images(out.mutable_data());
             return out;
           })
      .def("unwrapped_positions", [](const Sim& s) {
        Array a = new_n3(s.size());
        s.get_unwrapped_positions(a.mutable_data());
        return a;
      });
}

}  // namespace tsubu_py
