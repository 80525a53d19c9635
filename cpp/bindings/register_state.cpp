// tsubu::Simulation's state, in id order, as numpy arrays; energy, contacts and diagnostics.
#include <sstream>

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
  py::array_t<int> wall(m), element(m);
  Array overlap(m);
  Array force = new_n3(m), torque = new_n3(m), xi = new_n3(m), wall_point = new_n3(m), branch = new_n3(m);
  auto pi = i.mutable_unchecked<1>();
  auto pj = j.mutable_unchecked<1>();
  auto pw = wall.mutable_unchecked<1>();
  auto pe = element.mutable_unchecked<1>();
  auto po = overlap.mutable_unchecked<1>();
  auto pf = force.mutable_unchecked<2>();
  auto pt = torque.mutable_unchecked<2>();
  auto px = xi.mutable_unchecked<2>();
  auto pp = wall_point.mutable_unchecked<2>();
  auto pb = branch.mutable_unchecked<2>();
  for (std::size_t k = 0; k < m; ++k) {
    const auto& c = list[k];
    pi(k) = c.i;
    pj(k) = c.j;
    pw(k) = c.wall;
    pe(k) = c.element;
    po(k) = c.overlap;
    for (int d = 0; d < 3; ++d) {
      pf(k, d) = c.force[d];
      pt(k, d) = c.torque_i[d];
      px(k, d) = c.tangential_displacement[d];
      pp(k, d) = c.wall_point[d];
      pb(k, d) = c.branch[d];
    }
  }
  return py::dict("i"_a = i, "j"_a = j, "wall"_a = wall, "element"_a = element, "overlap"_a = overlap, "force"_a = force,
                  "torque_i"_a = torque, "tangential_displacement"_a = xi, "wall_point"_a = wall_point,
                  "branch"_a = branch);
}

// numpy (N, 3) input, checked against the number of spheres, to one of the set_* functions.
template <void (Sim::*set)(const double*)>
void set_n3(Sim& s, const Array& a, const char* name) {
  check_n3(a, s.size(), name);
  (s.*set)(a.data());
}

// Checkpoints: the run's counters and energy reference, and the touching contacts' state.
py::dict run_state_dict(const Sim& s) {
  const Sim::RunState r = s.run_state();
  const tsubu::Energy& e = r.energy_ref;
  return py::dict("step"_a = r.step, "time"_a = r.time, "ran"_a = r.ran,
                  "speed_fixed"_a = r.speed_fixed,
                  "energy_ref"_a = std::vector<double>{e.translational, e.rotational, e.gravitational,
                                                       e.elastic, e.dissipated, e.step_correction},
                  "energy_ref_valid"_a = r.energy_ref_valid, "energy_ref_step"_a = r.energy_ref_step,
                  "energy_ref_gravity"_a = from_vec3(r.energy_ref_gravity));
}

void set_run_state(Sim& s, const py::dict& d) {
  Sim::RunState r;
  r.step = d["step"].cast<long>();
  r.time = d["time"].cast<double>();
  r.ran = d["ran"].cast<bool>();
  r.speed_fixed = d["speed_fixed"].cast<double>();
  const auto e = d["energy_ref"].cast<std::array<double, 6>>();
  r.energy_ref = {e[0], e[1], e[2], e[3], e[4], e[5]};
  r.energy_ref_valid = d["energy_ref_valid"].cast<bool>();
  r.energy_ref_step = d["energy_ref_step"].cast<long>();
  r.energy_ref_gravity = to_vec3(d["energy_ref_gravity"].cast<std::array<double, 3>>());
  s.set_run_state(r);
}

using Ids = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

py::dict contact_state_dict(const Sim& s, bool walls) {
  const Sim::ContactState c = s.contact_state(walls);
  const py::ssize_t m = static_cast<py::ssize_t>(c.owner.size());
  py::list values, widths;
  for (std::size_t k = 0; k < c.values.size(); ++k) {
    Array a({m, py::ssize_t(c.widths[k])});
    std::copy(c.values[k].begin(), c.values[k].end(), a.mutable_data());
    values.append(a);
    widths.append(c.widths[k]);
  }
  const std::vector<std::int64_t> element(c.element.begin(), c.element.end());
  py::dict d("owner"_a = Ids(m, c.owner.data()), "partner"_a = Ids(m, c.partner.data()),
             "values"_a = values, "widths"_a = widths);
  if (walls) d["element"] = Ids(m, element.data());
  return d;
}

Sim::ContactState contact_state_from(const py::dict& d) {
  Sim::ContactState c;
  const Ids owner = d["owner"].cast<Ids>(), partner = d["partner"].cast<Ids>();
  c.owner.assign(owner.data(), owner.data() + owner.size());
  c.partner.assign(partner.data(), partner.data() + partner.size());
  if (d.contains("element")) {
    const Ids element = d["element"].cast<Ids>();
    c.element.assign(element.data(), element.data() + element.size());
  }
  const auto values = d["values"].cast<std::vector<Array>>();
  const auto widths = d["widths"].cast<std::vector<int>>();
  if (values.size() != c.values.size() || widths.size() != c.widths.size())
    throw tsubu::InvalidArgument("checkpoint state: " + std::to_string(c.values.size()) +
                                 " contact arrays expected");
  for (std::size_t k = 0; k < c.values.size(); ++k) {
    c.values[k].assign(values[k].data(), values[k].data() + values[k].size());
    c.widths[k] = widths[k];
  }
  return c;
}

// ---- stress (stress.cpp): sigma (3, 3) and, if asked, each sphere's sigma V (N, 3, 3).
py::tuple stress_arrays(const Sim& s, double volume, double rate, int flow, int gradient,
                        double reference, bool per_particle) {
  Array sigma({py::ssize_t(3), py::ssize_t(3)});
  py::object per = py::none();
  double* per_data = nullptr;
  if (per_particle) {
    Array a({static_cast<py::ssize_t>(s.size()), py::ssize_t(3), py::ssize_t(3)});
    per_data = a.mutable_data();
    per = a;
  }
  Sim::MeanFlow mean;
  mean.rate = rate;
  mean.flow = flow;
  mean.gradient = gradient;
  mean.reference = reference;
  s.stress(volume, mean, sigma.mutable_data(), per_data);
  return py::make_tuple(sigma, per);
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
          [](const Sim& s, bool at_positions, bool share) {
            if (at_positions && share) throw py::value_error("energy: a rank's share is of the last force evaluation");
            const tsubu::Energy e = at_positions ? s.energy_now() : s.energy(share);
            return py::dict("translational"_a = e.translational, "rotational"_a = e.rotational,
                            "kinetic"_a = e.kinetic(), "gravitational"_a = e.gravitational,
                            "elastic"_a = e.elastic, "total"_a = e.total(),
                            "dissipated"_a = e.dissipated, "step_correction"_a = e.step_correction);
          },
          "at_positions"_a = false, "share"_a = false)
      .def("contacts", &contacts_dict)
      .def("stress", &stress_arrays, "volume"_a, "rate"_a = 0.0, "flow"_a = 0, "gradient"_a = 2,
           "reference"_a = 0.0, "per_particle"_a = false)
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
      .def_property_readonly("near_reach", &Sim::near_reach)
      .def_property_readonly("fused_step_count", &Sim::fused_step_count)
      .def("phase_seconds",
           [](const Sim& s) {
             py::dict d;
             for (int p = 0; p < int(tsubu::Phase::Count); ++p)
               d[tsubu::phase_name(tsubu::Phase(p))] = s.phase_seconds()[p];
             return d;
           })
      .def("region_seconds",
           [](const Sim& s) {
             py::dict d;
             for (int r = 0; r < int(tsubu::Region::Count); ++r) {
               const tsubu::RegionTimes& t = s.region_seconds()[r];
               py::dict e;
               e["wall"] = t.wall, e["slowest"] = t.slowest, e["mean"] = t.mean, e["count"] = t.count;
               d[tsubu::region_name(tsubu::Region(r))] = e;
             }
             return d;
           })
      .def("memory_bytes",
           [](const Sim& s) {
             py::dict d;
             for (const auto& [name, bytes] : s.memory_bytes()) d[py::str(name)] = bytes;
             return d;
           })
      .def("skin", &Sim::skin)
      .def("run_state", &run_state_dict)
      .def("set_run_state", &set_run_state)
      .def("contact_state", &contact_state_dict, "walls"_a)
      .def(
          "set_contact_state",
          [](Sim& s, const py::dict& pairs, const py::dict& walls, bool wrap) {
            s.set_contact_state(contact_state_from(pairs), contact_state_from(walls), wrap);
          },
          "pairs"_a, "walls"_a, "wrap"_a = true)
      .def("save_bytes",
           [](const Sim& s) {
             std::ostringstream out;
             s.save(out);
             return py::bytes(out.str());
           },
           "The core's checkpoint of the whole scene (Simulation::save), as bytes")
      .def_static(
          "load_bytes",
          [](const py::bytes& data) {
            std::istringstream in{std::string(data)};
            return Sim::load(in);
          },
          "data"_a, "A Simulation from save_bytes()'s bytes (ValueError for bad ones)")
      .def("dissipated", &n1<double, &Sim::get_dissipated>)
      .def("set_dissipated",
           [](Sim& s, const Array& a) {
             if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != s.size())
               throw tsubu::InvalidArgument("dissipated must have shape (N,)");
             s.set_dissipated(a.data());
           })
      .def("set_plane_state",
           [](Sim& s, int wall, const std::array<double, 3>& point, const std::array<double, 3>& normal,
              const std::array<double, 3>& velocity, const std::array<double, 3>& angular_velocity,
              int material) {
             tsubu::Plane p;
             p.point = to_vec3(point);
             p.normal = to_vec3(normal);
             p.velocity = to_vec3(velocity);
             p.angular_velocity = to_vec3(angular_velocity);
             p.center = p.point;  // (these files' planes turn about their points)
             p.material = material;
             s.set_plane_state(wall, p);
           });
}

}  // namespace tsubu_py
