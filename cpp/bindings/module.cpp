// The pybind11 module tsubu._core: exception translation, the enum tables, then the classes
// (register_materials.cpp, register_options.cpp, register_simulation.cpp, register_state.cpp).
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

  // The accepted names of every string-valued argument, for the Python checks.
  py::dict choices;
  choices[Choices<tsubu::ScatterDistribution>::argument] = names<tsubu::ScatterDistribution>();
  choices[Choices<tsubu::ShadowRule>::argument] = names<tsubu::ShadowRule>();
  choices[Choices<tsubu::HistoryRule>::argument] = names<tsubu::HistoryRule>();
  choices[Choices<tsubu::SlipRule>::argument] = names<tsubu::SlipRule>();
  choices[Choices<tsubu::AdhesionLaw>::argument] = names<tsubu::AdhesionLaw>();
  m.attr("choices") = choices;
  m.attr("compiled_law_count") = tsubu::compiled_law_count();
  m.def("available_memory", &tsubu::available_memory,
        "Bytes the process can still allocate (MemAvailable, capped by the cgroup's limit).");

  register_materials(m);
  py::class_<tsubu::Simulation> sim(m, "Simulation");
  register_simulation(sim);
  register_state(sim);
  register_options(m);  // after Simulation: validate_options takes one
}
