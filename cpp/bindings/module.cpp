// The pybind11 module tsubu._core: exception translation, the classes (register_materials.cpp,
// register_options.cpp, register_simulation.cpp, register_state.cpp), then the names of the
// choices they bind.
#include "bindings.hpp"

using namespace tsubu_py;

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
    } catch (const tsubu::ResourceError& e) {
      PyErr_SetString(PyExc_MemoryError, e.what());
    }
  });

  m.attr("compiled_law_count") = tsubu::compiled_law_count();
  m.def("available_memory", &tsubu::available_memory,
        "Bytes the process can still allocate (MemAvailable, capped by the cgroup's limit).");

  register_materials(m);
  py::class_<tsubu::Simulation> sim(m, "Simulation");
  register_simulation(sim);
  register_state(sim);
  register_boundaries(sim);
  register_periodic(sim);
  register_options(m);  // after Simulation: validate_options takes one
  // The accepted names of every string-valued argument, for the Python checks (those the
  // registrations above bound).
  m.attr("choices") = bound_choices();
}

namespace tsubu_py {

namespace {
std::vector<const tsubu::OptionDeclaration*>& bound() {
  static std::vector<const tsubu::OptionDeclaration*> list;
  return list;
}
}  // namespace

void bound_choice(const tsubu::OptionDeclaration& d) { bound().push_back(&d); }

py::dict bound_choices() {
  py::dict out;
  for (const auto& d : tsubu::kOptionTable)
    for (const tsubu::OptionDeclaration* b : bound())
      if (b == &d) {
        py::list names;
        for (std::size_t k = 0; k < tsubu::choice_count(d.choices); ++k) names.append(d.choices[k]);
        out[d.name] = py::tuple(names);
        break;
      }
  return out;
}

}  // namespace tsubu_py
