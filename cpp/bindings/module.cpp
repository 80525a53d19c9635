// The pybind11 module: converts numpy arrays and forwards to tsubu::Simulation. Input checks with
// argument names live in python/tsubu; the C++ core checks again for C++ callers.
#include <optional>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "tsubu/simulation.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

tsubu::ScatterDistribution to_distribution(const std::string& name) {
  if (name == "normal") return tsubu::ScatterDistribution::Normal;
  if (name == "uniform") return tsubu::ScatterDistribution::Uniform;
  throw py::value_error("roughness_distribution must be 'normal' or 'uniform', got '" + name + "'");
}
const char* distribution_name(tsubu::ScatterDistribution d) {
  return d == tsubu::ScatterDistribution::Normal ? "normal" : "uniform";
}
tsubu::ShadowRule to_shadow(const std::string& name) {
  if (name == "reject") return tsubu::ShadowRule::Reject;
  if (name == "weighted") return tsubu::ShadowRule::Weighted;
  if (name == "none") return tsubu::ShadowRule::None;
  throw py::value_error("shadow must be 'reject', 'weighted' or 'none', got '" + name + "'");
}
const char* shadow_name(tsubu::ShadowRule r) {
  return r == tsubu::ShadowRule::Reject ? "reject" : r == tsubu::ShadowRule::Weighted ? "weighted" : "none";
}

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IntArray = py::array_t<int, py::array::c_style | py::array::forcecast>;

tsubu::Vec3 to_vec3(const std::array<double, 3>& a) { return tsubu::Vec3(a[0], a[1], a[2]); }
std::array<double, 3> from_vec3(const tsubu::Vec3& v) { return {v.x(), v.y(), v.z()}; }

const double* data_or_null(const std::optional<Array>& a) { return a ? a->data() : nullptr; }

Array new_n3(std::size_t n) { return Array({static_cast<py::ssize_t>(n), py::ssize_t(3)}); }

void check_n3(const Array& a, std::size_t n, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 3 || static_cast<std::size_t>(a.shape(0)) != n)
    throw py::value_error(std::string(name) + " must have shape (" + std::to_string(n) + ", 3)");
}

py::dict contacts_dict(const tsubu::Simulation& s) {
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

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "tsubu's compiled core (use the tsubu package, not this module)";
#ifdef TSUBU_HAVE_OPENMP
  m.attr("openmp") = true;
#else
  m.attr("openmp") = false;
#endif

  static py::exception<tsubu::InstabilityError> instability(m, "InstabilityError",
                                                            PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const tsubu::InstabilityError& e) {
      py::tuple args = py::make_tuple(e.what(), e.step, e.particle);
      PyErr_SetObject(instability.ptr(), args.ptr());
    } catch (const tsubu::InvalidArgument& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });

  py::class_<tsubu::Simulation>(m, "Simulation")
      .def(py::init<>())
      .def("add_material",
           [](tsubu::Simulation& s, double density, double kn, double kt, double restitution,
              double friction, double rolling_friction, double tangential_damping,
              double roughness, const std::string& distribution, const std::string& shadow) {
             tsubu::Material mat;
             mat.density = density;
             mat.kn = kn;
             mat.kt = kt;
             mat.restitution = restitution;
             mat.friction = friction;
             mat.rolling_friction = rolling_friction;
             mat.tangential_damping = tangential_damping;
             mat.roughness = roughness;
             mat.roughness_distribution = to_distribution(distribution);
             mat.shadow = to_shadow(shadow);
             return s.add_material(mat);
           },
           "density"_a, "kn"_a, "kt"_a, "restitution"_a, "friction"_a, "rolling_friction"_a,
           "tangential_damping"_a, "roughness"_a, "roughness_distribution"_a, "shadow"_a)
      .def("set_pair_parameters",
           [](tsubu::Simulation& s, int a, int b, double kn, double kt, double restitution,
              double friction, double rolling_friction, double tangential_damping,
              double roughness, const std::string& distribution, const std::string& shadow) {
             tsubu::PairParams p;
             p.roughness = roughness;
             p.roughness_distribution = to_distribution(distribution);
             p.shadow = to_shadow(shadow);
             p.kn = kn;
             p.kt = kt;
             p.restitution = restitution;
             p.friction = friction;
             p.rolling_friction = rolling_friction;
             p.tangential_damping = tangential_damping;
             s.set_pair_parameters(a, b, p);
           })
      .def("pair_parameters",
           [](const tsubu::Simulation& s, int a, int b) {
             const tsubu::PairParams p = s.pair_parameters(a, b);
             return py::dict("kn"_a = p.kn, "kt"_a = p.kt, "restitution"_a = p.restitution,
                             "friction"_a = p.friction, "rolling_friction"_a = p.rolling_friction,
                             "tangential_damping"_a = p.tangential_damping,
                             "roughness"_a = p.roughness,
                             "roughness_distribution"_a = distribution_name(p.roughness_distribution),
                             "shadow"_a = shadow_name(p.shadow));
           })
      .def("reserve", &tsubu::Simulation::reserve)
      .def("add_spheres",
           [](tsubu::Simulation& s, const Array& x, const Array& r, const IntArray& mat,
              std::optional<Array> v, std::optional<Array> w) {
             const std::size_t n = static_cast<std::size_t>(r.shape(0));
             check_n3(x, n, "positions");
             if (v) check_n3(*v, n, "velocities");
             if (w) check_n3(*w, n, "angular_velocities");
             if (static_cast<std::size_t>(mat.size()) != n)
               throw py::value_error("materials must have one entry per sphere");
             return s.add_spheres(n, x.data(), r.data(), mat.data(), data_or_null(v),
                                  data_or_null(w));
           })
      .def("add_plane",
           [](tsubu::Simulation& s, std::array<double, 3> point, std::array<double, 3> normal,
              int mat, std::array<double, 3> vel, std::array<double, 3> angvel) {
             return s.add_plane(to_vec3(point), to_vec3(normal), mat, to_vec3(vel),
                                to_vec3(angvel));
           })
      .def("set_plane_motion",
           [](tsubu::Simulation& s, int wall, std::array<double, 3> vel,
              std::array<double, 3> angvel) {
             s.set_plane_motion(wall, to_vec3(vel), to_vec3(angvel));
           })
      .def("plane",
           [](const tsubu::Simulation& s, int wall) {
             const tsubu::Plane& p = s.plane(wall);
             return py::dict("point"_a = from_vec3(p.point), "normal"_a = from_vec3(p.normal),
                             "velocity"_a = from_vec3(p.velocity),
                             "angular_velocity"_a = from_vec3(p.angular_velocity),
                             "material"_a = p.material);
           })
      .def_property_readonly("plane_count", &tsubu::Simulation::plane_count)
      // options
      .def_property(
          "gravity", [](const tsubu::Simulation& s) { return from_vec3(s.options().gravity); },
          [](tsubu::Simulation& s, std::array<double, 3> g) { s.options().gravity = to_vec3(g); })
      .def_property(
          "dt", [](const tsubu::Simulation& s) { return s.options().dt; },
          [](tsubu::Simulation& s, double dt) { s.options().dt = dt; })
      .def_property(
          "parallel_min", [](const tsubu::Simulation& s) { return s.options().parallel_min; },
          [](tsubu::Simulation& s, int v) { s.options().parallel_min = v; })
      .def_property(
          "seed", [](const tsubu::Simulation& s) { return s.options().seed; },
          [](tsubu::Simulation& s, std::uint64_t v) { s.options().seed = v; })
      .def_property(
          "threads", [](const tsubu::Simulation& s) { return s.options().threads; },
          [](tsubu::Simulation& s, int t) { s.options().threads = t; })
      .def_property(
          "skin_option", [](const tsubu::Simulation& s) { return s.options().skin; },
          [](tsubu::Simulation& s, double v) { s.options().skin = v; })
      .def_property(
          "history_rule",
          [](const tsubu::Simulation& s) {
            return s.options().history == tsubu::HistoryRule::Rotate ? "rotate" : "literal";
          },
          [](tsubu::Simulation& s, const std::string& rule) {
            if (rule == "rotate")
              s.options().history = tsubu::HistoryRule::Rotate;
            else if (rule == "literal")
              s.options().history = tsubu::HistoryRule::Literal;
            else
              throw py::value_error("tangential_history must be 'rotate' or 'literal'");
          })
      .def_property(
          "slip_rule",
          [](const tsubu::Simulation& s) {
            return s.options().slip == tsubu::SlipRule::Frozen ? "frozen" : "truncate";
          },
          [](tsubu::Simulation& s, const std::string& rule) {
            if (rule == "frozen")
              s.options().slip = tsubu::SlipRule::Frozen;
            else if (rule == "truncate")
              s.options().slip = tsubu::SlipRule::Truncate;
            else
              throw py::value_error("slip_rule must be 'frozen' or 'truncate'");
          })
      .def_property(
          "max_overlap", [](const tsubu::Simulation& s) { return s.options().max_overlap; },
          [](tsubu::Simulation& s, double v) { s.options().max_overlap = v; })
      .def_property(
          "initial_overlap", [](const tsubu::Simulation& s) { return s.options().initial_overlap; },
          [](tsubu::Simulation& s, double v) { s.options().initial_overlap = v; })
      .def_property(
          "allow_unstable_dt",
          [](const tsubu::Simulation& s) { return s.options().allow_unstable_dt; },
          [](tsubu::Simulation& s, bool v) { s.options().allow_unstable_dt = v; })
      .def_property(
          "rebuild_every_step",
          [](const tsubu::Simulation& s) { return s.options().rebuild_every_step; },
          [](tsubu::Simulation& s, bool v) { s.options().rebuild_every_step = v; })
      // time stepping
      .def("critical_time_step", &tsubu::Simulation::critical_time_step)
      .def("contact_duration", &tsubu::Simulation::contact_duration)
      .def("default_time_step", &tsubu::Simulation::default_time_step)
      .def("time_step", &tsubu::Simulation::time_step)
      .def("run", &tsubu::Simulation::run, "steps"_a, py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("step_count", &tsubu::Simulation::step_count)
      .def_property_readonly("time", &tsubu::Simulation::time)
      .def("law_name", &tsubu::Simulation::law_name)
      .def("threads_used", &tsubu::Simulation::threads_used)
      // state
      .def_property_readonly("size", &tsubu::Simulation::size)
      .def("positions", [](const tsubu::Simulation& s) {
        Array a = new_n3(s.size());
        s.get_positions(a.mutable_data());
        return a;
      })
      .def("velocities", [](const tsubu::Simulation& s) {
        Array a = new_n3(s.size());
        s.get_velocities(a.mutable_data());
        return a;
      })
      .def("angular_velocities", [](const tsubu::Simulation& s) {
        Array a = new_n3(s.size());
        s.get_angular_velocities(a.mutable_data());
        return a;
      })
      .def("forces", [](const tsubu::Simulation& s) {
        Array a = new_n3(s.size());
        s.get_forces(a.mutable_data());
        return a;
      })
      .def("torques", [](const tsubu::Simulation& s) {
        Array a = new_n3(s.size());
        s.get_torques(a.mutable_data());
        return a;
      })
      .def("radii", [](const tsubu::Simulation& s) {
        Array a(static_cast<py::ssize_t>(s.size()));
        s.get_radii(a.mutable_data());
        return a;
      })
      .def("masses", [](const tsubu::Simulation& s) {
        Array a(static_cast<py::ssize_t>(s.size()));
        s.get_masses(a.mutable_data());
        return a;
      })
      .def("materials", [](const tsubu::Simulation& s) {
        py::array_t<int> a(static_cast<py::ssize_t>(s.size()));
        s.get_materials(a.mutable_data());
        return a;
      })
      .def("set_positions",
           [](tsubu::Simulation& s, const Array& a) {
             check_n3(a, s.size(), "positions");
             s.set_positions(a.data());
           })
      .def("set_velocities",
           [](tsubu::Simulation& s, const Array& a) {
             check_n3(a, s.size(), "velocities");
             s.set_velocities(a.data());
           })
      .def("set_angular_velocities",
           [](tsubu::Simulation& s, const Array& a) {
             check_n3(a, s.size(), "angular_velocities");
             s.set_angular_velocities(a.data());
           })
      .def("energy",
           [](const tsubu::Simulation& s, bool at_positions) {
             const tsubu::Energy e = at_positions ? s.energy_now() : s.energy();
             return py::dict("translational"_a = e.translational, "rotational"_a = e.rotational,
                             "kinetic"_a = e.kinetic(), "gravitational"_a = e.gravitational,
                             "elastic"_a = e.elastic, "total"_a = e.total(),
                             "dissipated"_a = e.dissipated, "step_correction"_a = e.step_correction);
           },
           "at_positions"_a = false)
      .def("contacts", &contacts_dict)
      .def("rebuild_neighbors", &tsubu::Simulation::rebuild_neighbors)
      .def("neighbor_pairs",
           [](const tsubu::Simulation& s) {
             const auto pairs = s.neighbor_pairs();
             py::array_t<std::int64_t> a({static_cast<py::ssize_t>(pairs.size()), py::ssize_t(2)});
             auto p = a.mutable_unchecked<2>();
             for (std::size_t k = 0; k < pairs.size(); ++k) {
               p(k, 0) = pairs[k][0];
               p(k, 1) = pairs[k][1];
             }
             return a;
           })
      .def_property_readonly("rebuild_count", &tsubu::Simulation::rebuild_count)
      .def("phase_seconds",
           [](const tsubu::Simulation& s) {
             py::dict d;
             for (int p = 0; p < int(tsubu::Phase::Count); ++p)
               d[tsubu::phase_name(tsubu::Phase(p))] = s.phase_seconds()[p];
             return d;
           })
      .def("memory_bytes",
           [](const tsubu::Simulation& s) {
             py::dict d;
             for (const auto& [name, bytes] : s.memory_bytes()) d[py::str(name)] = bytes;
             return d;
           })
      .def_property_readonly("near_refresh_count", &tsubu::Simulation::near_refresh_count)
      .def_property_readonly("fused_step_count", &tsubu::Simulation::fused_step_count)
      .def("skin", &tsubu::Simulation::skin);
}
