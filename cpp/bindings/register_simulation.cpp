// tsubu::Simulation: set-up, options and time stepping.
#include "bindings.hpp"

namespace tsubu_py {

namespace {

using Sim = tsubu::Simulation;

// An option of tsubu::Options as a read-write property.
template <class T>
void option(py::class_<Sim>& cls, const char* name, T tsubu::Options::*member) {
  cls.def_property(
      name, [member](const Sim& s) { return s.options().*member; },
      [member](Sim& s, T v) { s.options().*member = v; });
}
// An enum option, as its name (the names of the option `declared`).
template <class E>
void enum_option(py::class_<Sim>& cls, const char* name, const char* declared, E tsubu::Options::*member) {
  const tsubu::OptionDeclaration* d = &tsubu::declaration_of(declared);
  cls.def_property(
      name, [member, d](const Sim& s) { return choice_name(*d, static_cast<int>(s.options().*member)); },
      [member, d](Sim& s, const std::string& v) { s.options().*member = static_cast<E>(parse_choice(*d, v)); });
  bound_choice(*d);
}
// Every law choice (Options::law_choices), as its name, under its declared name.
void law_choices(py::class_<Sim>& cls) {
  tsubu::for_each_law_choice([&](const tsubu::OptionDeclaration& declared, std::size_t slot) {
    const tsubu::OptionDeclaration* d = &declared;
    cls.def_property(
        d->name, [d, slot](const Sim& s) { return choice_name(*d, s.options().law_choices[slot]); },
        [d, slot](Sim& s, const std::string& v) { s.options().law_choices[slot] = parse_choice(*d, v); });
    bound_choice(*d);
  });
}

// Python runs signal handlers on its main thread only.
unsigned long main_thread_ident = 0;
constexpr double kSignalPollSeconds = 0.02;

// Runs with the GIL released. On the main thread, every 20 ms of wall time the run takes the
// GIL back to run pending signal handlers: one that raises (SIGINT's KeyboardInterrupt) stops
// the run after its current step, and the exception is raised here once the run has returned.
// `audit`: check the energy balance when the run ends (Simulation::run); the Python layer, which
// cuts a run into stretches between its hooks, passes false and audits once at the end.
long run_checking_signals(Sim& s, long steps, bool audit) {
  std::optional<py::error_already_set> raised;
  const std::function<bool()> check_signals = [&raised] {
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return false;
    raised.emplace();  // takes the error from Python's error indicator
    return true;
  };
  const bool on_main = PyThread_get_thread_ident() == main_thread_ident;
  long taken;
  {
    py::gil_scoped_release release;
    taken = on_main ? s.run(steps, check_signals, kSignalPollSeconds, audit)
                    : s.run(steps, {}, kSignalPollSeconds, audit);
  }
  if (raised) throw *raised;
  return taken;
}

}  // namespace

void register_simulation(py::class_<Sim>& cls) {
  main_thread_ident = py::module_::import("threading").attr("main_thread")().attr("ident")
                          .cast<unsigned long>();
  using namespace pybind11::literals;
  cls.def(py::init<>())
      .def("add_material", &Sim::add_material, "material"_a)
      .def_property_readonly("material_count", &Sim::material_count)
      .def("set_pair_parameters", &Sim::set_pair_parameters, "a"_a, "b"_a, "params"_a)
      .def("pair_parameters", &Sim::pair_parameters, "a"_a, "b"_a)
      .def("reserve", &Sim::reserve, "count"_a)
      .def(
          "add_spheres",
          [](Sim& s, const Array& x, const Array& r, const IntArray& mat, std::optional<Array> v,
             std::optional<Array> w, bool check_overlaps) {
            const std::size_t n = static_cast<std::size_t>(r.shape(0));
            check_n3(x, n, "positions");
            if (v) check_n3(*v, n, "velocities");
            if (w) check_n3(*w, n, "angular_velocities");
            if (static_cast<std::size_t>(mat.size()) != n)
              throw py::value_error("materials must have one entry per sphere");
            return s.add_spheres(n, x.data(), r.data(), mat.data(), data_or_null(v),
                                 data_or_null(w), check_overlaps);
          },
          "positions"_a, "radii"_a, "materials"_a, "velocities"_a, "angular_velocities"_a,
          "check_overlaps"_a = true)
      .def(
          "add_plane",
          [](Sim& s, std::array<double, 3> point, std::array<double, 3> normal, int mat,
             std::array<double, 3> vel, std::array<double, 3> angvel) {
            return s.add_plane(to_vec3(point), to_vec3(normal), mat, to_vec3(vel), to_vec3(angvel));
          },
          "point"_a, "normal"_a, "material"_a, "velocity"_a, "angular_velocity"_a)
      .def(
          "add_plane",
          [](Sim& s, std::array<double, 3> point, std::array<double, 3> normal, int mat,
             std::array<double, 3> vel, std::array<double, 3> angvel, std::array<double, 3> center) {
            return s.add_plane(to_vec3(point), to_vec3(normal), mat, to_vec3(vel), to_vec3(angvel),
                               to_vec3(center));
          },
          "point"_a, "normal"_a, "material"_a, "velocity"_a, "angular_velocity"_a, "center"_a)
      .def(
          "add_mesh",
          [](Sim& s, const py::array_t<double, py::array::c_style | py::array::forcecast>& vertices,
             const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>& faces, int mat,
             std::array<double, 3> vel, std::array<double, 3> angvel, std::array<double, 3> center) {
            if (vertices.ndim() != 2 || vertices.shape(1) != 3) throw py::value_error("vertices must have shape (V, 3)");
            if (faces.ndim() != 2 || faces.shape(1) != 3) throw py::value_error("faces must have shape (F, 3)");
            std::vector<tsubu::Vec3> v(static_cast<std::size_t>(vertices.shape(0)));
            for (std::size_t k = 0; k < v.size(); ++k)
              v[k] = tsubu::Vec3(vertices.at(k, 0), vertices.at(k, 1), vertices.at(k, 2));
            std::vector<tsubu::Mesh::Face> f(static_cast<std::size_t>(faces.shape(0)));
            for (std::size_t k = 0; k < f.size(); ++k)
              for (std::size_t j = 0; j < 3; ++j) {
                const std::int64_t idx = faces.at(k, j);
                if (idx < 0 || idx >= std::int64_t(v.size()))
                  throw py::value_error("faces: triangle " + std::to_string(k) + " names vertex " + std::to_string(idx) +
                                        "; there are " + std::to_string(v.size()));
                f[k][j] = static_cast<tsubu::Index>(idx);
              }
            return s.add_mesh(v, f, mat, to_vec3(vel), to_vec3(angvel), to_vec3(center));
          },
          "vertices"_a, "faces"_a, "material"_a, "velocity"_a, "angular_velocity"_a, "center"_a)
      .def("set_wall_center",
           [](Sim& s, int wall, std::array<double, 3> c) { s.set_wall_center(wall, to_vec3(c)); }, "wall"_a,
           "center"_a)
      .def("remove_wall", &Sim::remove_wall, "wall"_a)
      .def(
          "set_wall_servo",
          [](Sim& s, int wall, std::array<double, 3> direction, double force, double gain, double max_speed) {
            s.set_wall_servo(wall, to_vec3(direction), force, gain, max_speed);
          },
          "wall"_a, "direction"_a, "force"_a, "gain"_a, "max_speed"_a)
      .def("clear_wall_servo", &Sim::clear_wall_servo, "wall"_a)
      .def(
          "wall",
          [](const Sim& s, int wall) {
            const tsubu::Plane& p = s.plane(wall);
            const bool mesh = s.walls().kind(wall) == tsubu::Walls::kMesh;
            py::dict d("kind"_a = mesh ? "mesh" : "plane", "center"_a = from_vec3(p.center),
                       "velocity"_a = from_vec3(p.velocity), "angular_velocity"_a = from_vec3(p.angular_velocity),
                       "material"_a = p.material, "removed"_a = s.walls().removed(wall));
            const tsubu::Walls::Servo& servo = s.walls().servo(wall);
            if (servo.on)
              d["servo"] = py::dict("direction"_a = from_vec3(servo.direction), "force"_a = servo.force,
                                    "gain"_a = servo.gain, "max_speed"_a = servo.max_speed);
            if (!mesh) {
              d["point"] = from_vec3(p.point);
              d["normal"] = from_vec3(p.normal);
              return d;
            }
            const tsubu::Mesh& m = s.walls().mesh(wall);
            const std::vector<tsubu::Vec3> v = m.world_vertices();
            py::array_t<double> vertices({py::ssize_t(v.size()), py::ssize_t(3)});
            auto pv = vertices.mutable_unchecked<2>();
            for (std::size_t k = 0; k < v.size(); ++k)
              for (int c = 0; c < 3; ++c) pv(py::ssize_t(k), c) = v[k][c];
            py::array_t<std::int64_t> faces({py::ssize_t(m.triangles()), py::ssize_t(3)});
            auto pf = faces.mutable_unchecked<2>();
            for (std::size_t k = 0; k < m.faces().size(); ++k)
              for (int c = 0; c < 3; ++c) pf(py::ssize_t(k), c) = m.faces()[k][std::size_t(c)];
            d["vertices"] = vertices;
            d["faces"] = faces;
            return d;
          },
          "wall"_a)
      .def("wall_loads",
           [](const Sim& s) {
             std::vector<tsubu::Vec3> f, t;
             s.wall_loads(f, t);
             py::array_t<double> forces({py::ssize_t(f.size()), py::ssize_t(3)}),
                 torques({py::ssize_t(f.size()), py::ssize_t(3)});
             auto pf = forces.mutable_unchecked<2>();
             auto pt = torques.mutable_unchecked<2>();
             for (std::size_t k = 0; k < f.size(); ++k)
               for (int c = 0; c < 3; ++c) pf(py::ssize_t(k), c) = f[k][c], pt(py::ssize_t(k), c) = t[k][c];
             return py::make_tuple(forces, torques);
           })
      .def(
          "set_plane_motion",
          [](Sim& s, int wall, std::array<double, 3> vel, std::array<double, 3> angvel) {
            s.set_plane_motion(wall, to_vec3(vel), to_vec3(angvel));
          },
          "wall"_a, "velocity"_a, "angular_velocity"_a)
      .def(
          "plane",
          [](const Sim& s, int wall) {
            const tsubu::Plane& p = s.plane(wall);
            return py::dict("point"_a = from_vec3(p.point), "normal"_a = from_vec3(p.normal),
                            "velocity"_a = from_vec3(p.velocity),
                            "angular_velocity"_a = from_vec3(p.angular_velocity),
                            "material"_a = p.material);
          },
          "wall"_a)
      .def_property_readonly("plane_count", &Sim::plane_count);

  cls.def_property(
      "gravity", [](const Sim& s) { return from_vec3(s.options().gravity); },
      [](Sim& s, std::array<double, 3> g) { s.options().gravity = to_vec3(g); });
  option(cls, "dt", &tsubu::Options::dt);
  option(cls, "parallel_min", &tsubu::Options::parallel_min);
  option(cls, "seed", &tsubu::Options::seed);
  option(cls, "threads", &tsubu::Options::threads);
  option(cls, "skin_option", &tsubu::Options::skin);
  option(cls, "max_overlap", &tsubu::Options::max_overlap);
  option(cls, "initial_overlap", &tsubu::Options::initial_overlap);
  option(cls, "allow_unstable_dt", &tsubu::Options::allow_unstable_dt);
  option(cls, "rebuild_every_step", &tsubu::Options::rebuild_every_step);
  cls.def_property("_mesh_sheets", &Sim::mesh_sheets, &Sim::set_mesh_sheets);  // (testing aids)
  cls.def_property_readonly("_mesh_sheet_count", &Sim::mesh_sheet_count);
  cls.def_property_readonly("_list_sizes", &Sim::list_sizes);
  enum_option(cls, "history_rule", "tangential_history", &tsubu::Options::history);
  enum_option(cls, "slip_rule", "slip_rule", &tsubu::Options::slip);
  law_choices(cls);
  option(cls, "repulsive", &tsubu::Options::repulsive);
  option(cls, "impact_speed", &tsubu::Options::impact_speed);

  cls.def("critical_time_step", &Sim::critical_time_step)
      .def("contact_duration", &Sim::contact_duration)
      .def("default_time_step", &Sim::default_time_step)
      .def("rayleigh_time", &Sim::rayleigh_time)
      .def("characteristic_speed", &Sim::characteristic_speed)
      .def("time_step", &Sim::time_step)
      .def("run", &run_checking_signals, "steps"_a, "audit"_a = true)
      .def("audit_run_end", &Sim::audit_run_end, "start"_a)
      .def("prepare_run", &Sim::prepare_run)
      .def_property_readonly("neighbor_pair_count", &Sim::neighbor_pair_count)
      .def("request_stop", &Sim::request_stop)
      .def_property_readonly("stopped", &Sim::stopped)
      .def_property_readonly("running", &Sim::running)
      .def_property_readonly("step_count", &Sim::step_count)
      .def_property_readonly("time", &Sim::time)
      .def("law_name", &Sim::law_name)
      .def("threads_used", &Sim::threads_used);
}

}  // namespace tsubu_py
