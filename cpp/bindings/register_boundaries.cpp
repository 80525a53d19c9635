// Grains as boundaries (tsubu/boundary.hpp): fixed and prescribed spheres, removal, outlets and
// the log of the spheres removed.
#include "bindings.hpp"

namespace tsubu_py {

namespace {
using Sim = tsubu::Simulation;
using Ids = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

std::size_t count_of(const Ids& ids) {
  if (ids.ndim() != 1) throw py::value_error("ids must be a 1-d array");
  return static_cast<std::size_t>(ids.shape(0));
}
}  // namespace

void register_boundaries(py::class_<Sim>& cls) {
  using namespace pybind11::literals;
  cls.def(
         "remove_spheres",
         [](Sim& s, const Ids& ids) { s.remove_spheres(count_of(ids), ids.data()); }, "ids"_a)
      .def(
          "fix_spheres",
          [](Sim& s, const Ids& ids, const Array& v, const Array& w) {
            const std::size_t n = count_of(ids);
            check_n3(v, n, "velocities");
            check_n3(w, n, "angular_velocities");
            s.fix_spheres(n, ids.data(), v.data(), w.data());
          },
          "ids"_a, "velocities"_a, "angular_velocities"_a)
      .def(
          "free_spheres", [](Sim& s, const Ids& ids) { s.free_spheres(count_of(ids), ids.data()); },
          "ids"_a)
      .def("get_fixed",
           [](const Sim& s) {
             py::array_t<std::uint8_t> out(static_cast<py::ssize_t>(s.size()));
             s.get_fixed(out.mutable_data());
             return out.attr("astype")("bool");
           })
      .def("fixed_motion",
           [](const Sim& s) {
             const tsubu::FixedSpheres& f = s.fixed_spheres();
             const std::size_t n = f.ids.size();
             py::array_t<std::int64_t> ids(static_cast<py::ssize_t>(n));
             Array v = new_n3(n), w = new_n3(n);
             std::copy(f.ids.begin(), f.ids.end(), ids.mutable_data());
             std::copy(f.v.begin(), f.v.end(), v.mutable_data());
             std::copy(f.w.begin(), f.w.end(), w.mutable_data());
             return py::dict("ids"_a = ids, "velocities"_a = v, "angular_velocities"_a = w);
           })
      .def("get_ids",
           [](const Sim& s) {
             py::array_t<std::int64_t> out(static_cast<py::ssize_t>(s.size()));
             s.get_ids(out.mutable_data());
             return out;
           })
      .def(
          "add_outlet",
          [](Sim& s, int kind, std::array<double, 3> a, std::array<double, 3> b, bool inside) {
            tsubu::Outlet o;
            o.kind = kind;
            o.a = to_vec3(a);
            o.b = to_vec3(b);
            o.remove_inside = inside;
            return s.add_outlet(o);
          },
          "kind"_a, "a"_a, "b"_a, "remove_inside"_a)
      .def("outlets",
           [](const Sim& s) {
             py::list out;
             for (const tsubu::Outlet& o : s.outlets())
               out.append(py::dict("kind"_a = o.kind, "a"_a = from_vec3(o.a), "b"_a = from_vec3(o.b),
                                   "remove_inside"_a = o.remove_inside));
             return out;
           })
      .def("removed", [](const Sim& s) {
        const tsubu::RemovalLog& r = s.removed();
        const std::size_t n = r.size();
        py::array_t<std::int64_t> id(static_cast<py::ssize_t>(n)), step(static_cast<py::ssize_t>(n));
        py::array_t<int> outlet(static_cast<py::ssize_t>(n));
        Array time(static_cast<py::ssize_t>(n));
        Array x = new_n3(n), v = new_n3(n);
        std::copy(r.id.begin(), r.id.end(), id.mutable_data());
        std::copy(r.step.begin(), r.step.end(), step.mutable_data());
        std::copy(r.outlet.begin(), r.outlet.end(), outlet.mutable_data());
        std::copy(r.time.begin(), r.time.end(), time.mutable_data());
        std::copy(r.position.begin(), r.position.end(), x.mutable_data());
        std::copy(r.velocity.begin(), r.velocity.end(), v.mutable_data());
        return py::dict("id"_a = id, "outlet"_a = outlet, "step"_a = step, "time"_a = time,
                        "position"_a = x, "velocity"_a = v);
      });

  // A domain decomposition's halo (tsubu.parallel, docs/parallel.md).
  cls.def(
         "_insert_spheres",
         [](Sim& s, const Ids& ids, const Array& x, const Array& r, const IntArray& m, const Array& v,
            const Array& w, const Array& dissipated, bool carry, std::optional<Ids> images,
            std::optional<Array> slid, bool check) {
           const std::size_t n = count_of(ids);
           check_n3(x, n, "positions");
           check_n3(v, n, "velocities");
           check_n3(w, n, "angular_velocities");
           if (static_cast<std::size_t>(r.size()) != n || static_cast<std::size_t>(m.size()) != n ||
               static_cast<std::size_t>(dissipated.size()) != n)
             throw py::value_error("radii, materials and dissipated must have one value per id");
           if (images && static_cast<std::size_t>(images->size()) != 3 * n)
             throw py::value_error("images must have shape (" + std::to_string(n) + ", 3)");
           s.insert_spheres(n, ids.data(), x.data(), r.data(), m.data(), v.data(), w.data(), dissipated.data(),
                            carry, images ? images->data() : nullptr, slid ? slid->data() : nullptr, check);
         },
         "ids"_a, "positions"_a, "radii"_a, "materials"_a, "velocities"_a, "angular_velocities"_a,
         "dissipated"_a, "carry"_a = true, "images"_a = py::none(), "slid"_a = py::none(), "check"_a = false)
      .def(
          "_drop_spheres",
          [](Sim& s, const Ids& ids, bool carry) { s.drop_spheres(count_of(ids), ids.data(), carry); },
          "ids"_a, "carry"_a = true)
      .def("_pack_halo",
           [](const Sim& s, const Ids& ids, py::array_t<double, py::array::c_style> out) {
             if (static_cast<std::size_t>(out.size()) < 1 + 10 * count_of(ids))
               throw py::value_error("out must hold 1 + 10 values per id");
             return s.pack_halo(count_of(ids), ids.data(), out.mutable_data());
           },
           "ids"_a, "out"_a)
      .def("_unpack_halo",
           [](Sim& s, const Ids& ids, const Array& in) {
             if (in.size() < 1) throw py::value_error("values must hold the count first");
             const double m = in.data()[0];
             const std::size_t n = count_of(ids);
             if (!(m >= 0 && m <= static_cast<double>(n)) ||
                 static_cast<std::size_t>(in.size()) < 1 + (m == n ? 9 : 10) * static_cast<std::size_t>(m))
               throw py::value_error("values: a message for another list (count " + std::to_string(m) + ")");
             return s.unpack_halo(n, ids.data(), in.data());
           },
           "ids"_a, "values"_a)
      .def(
          "_set_exchange",
          [](Sim& s, py::object f) {
            if (f.is_none()) return s.set_exchange({});
            // The loop calls it with the GIL released (run_checking_signals).
            s.set_exchange([f](double vmax2, double rel2) {
              py::gil_scoped_acquire gil;
              return f(vmax2, rel2).cast<std::array<double, 3>>();
            });
          },
          "exchange"_a)
      .def_property_readonly("_has_exchange", &Sim::has_exchange)
      .def("_raw_state",
           [](const Sim& s, const Ids& ids) {
             // x, v, w as stored (a periodic box's spheres unwrapped until the next rebuild),
             // image counters and slides, of the listed ids (all held).
             const std::size_t n = count_of(ids);
             Array out({static_cast<py::ssize_t>(n), py::ssize_t(9)}), slid(static_cast<py::ssize_t>(n));
             py::array_t<std::int64_t> images({static_cast<py::ssize_t>(n), py::ssize_t(3)});
             if (s.pack_state(n, ids.data(), out.mutable_data(), images.mutable_data(), slid.mutable_data()) != n)
               throw tsubu::InvalidArgument("_raw_state: an id is not held");
             return py::make_tuple(out, images, slid);
           },
           "ids"_a)
      .def("_set_own", [](Sim& s, const Ids& ids) { s.set_own(count_of(ids), ids.data()); }, "ids"_a)
      .def("_own_speeds", &Sim::own_speeds)
      .def_property(
          "_moved_bounds", &Sim::moved_bounds,
          [](Sim& s, std::array<double, 2> m) { s.set_moved_bounds(m[0], m[1]); })
      .def(
          "_set_removed",
          [](Sim& s, const Ids& id, const IntArray& outlet, const Ids& step, const Array& time,
             const Array& x, const Array& v) {
            const std::size_t n = count_of(id);
            check_n3(x, n, "position");
            check_n3(v, n, "velocity");
            if (static_cast<std::size_t>(outlet.size()) != n || static_cast<std::size_t>(step.size()) != n ||
                static_cast<std::size_t>(time.size()) != n)
              throw py::value_error("the removal log's arrays must have one row per id");
            tsubu::RemovalLog log;
            log.id.assign(id.data(), id.data() + n);
            log.outlet.assign(outlet.data(), outlet.data() + n);
            log.step.assign(step.data(), step.data() + n);
            log.time.assign(time.data(), time.data() + n);
            log.position.assign(x.data(), x.data() + 3 * n);
            log.velocity.assign(v.data(), v.data() + 3 * n);
            s.set_removed(std::move(log));
          },
          "id"_a, "outlet"_a, "step"_a, "time"_a, "position"_a, "velocity"_a);
}

}  // namespace tsubu_py
