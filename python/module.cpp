// The compiled module `polydem`: the engine's concepts for numpy users (docs/python.md). This file: the
// exceptions, the Box, the version; the other concepts are bound in one file each (distributions.cpp,
// broadphase.cpp, simulation.cpp, jamming.cpp, analysis.cpp, io.cpp).
#include <pybind11/eigen.h>
#include <pybind11/operators.h>
#include <pybind11/stl.h>

#include "core/errors.hpp"
#include "polydem/config.hpp"
#include "python/convert.hpp"

namespace py = pybind11;
using namespace polydem;
using namespace polydem::python;

namespace {

/// The Python classes of the engine's errors. InputError (a file that cannot be read, written or parsed)
/// derives from both OSError and ValueError, as io.UnsupportedOperation does, so `except OSError` catches
/// a missing or unwritable file and `except ValueError` a malformed one.
struct ErrorTypes {
  PyObject* config = nullptr;
  PyObject* input = nullptr;
  PyObject* simulation = nullptr;
};
ErrorTypes errors;

PyObject* newError(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  const std::string qualified = std::string("polydem.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases, nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(type));
  return type;
}

void bindErrors(py::module_& m) {
  errors.config = newError(m, "ConfigError", PyExc_ValueError,
                           "A scene key, option or argument is invalid; the message names it (C++ ConfigError).");
  py::tuple inputBases = py::make_tuple(py::handle(PyExc_OSError), py::handle(PyExc_ValueError));
  errors.input = newError(m, "InputError", inputBases.ptr(),
                          "A file cannot be read or written, or is malformed; the message names the file and line (C++ "
                          "InputError). Subclass of OSError and ValueError.");
  errors.simulation =
      newError(m, "SimulationError", PyExc_RuntimeError,
               "A run became unstable; the message names the step and particles (C++ SimulationError).");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ConfigError& e) {
      PyErr_SetString(errors.config, e.what());
    } catch (const InputError& e) {
      PyErr_SetString(errors.input, e.what());
    } catch (const SimulationError& e) {
      PyErr_SetString(errors.simulation, e.what());
    }
  });
}

void bindBox(py::module_& m) {
  py::class_<Box>(m, "Box", "Simulation box [0, Lx) x [0, Ly) x [0, Lz), each axis periodic or walled.")
      .def(py::init(
               [](const py::object& lengths, const py::object& boundaries) { return boxFrom(lengths, boundaries); }),
           py::arg("lengths"), py::arg("boundaries") = "periodic",
           "Box(lengths=(Lx, Ly, Lz), boundaries='periodic' | 'walls' | 'periodic,periodic,wall')")
      .def_property_readonly("lengths",
                             [](const Box& b) { return py::make_tuple(b.length(0), b.length(1), b.length(2)); })
      .def_property_readonly("boundaries", [](const Box& b) { return boundaryWords(b); })
      .def_property_readonly("volume", &Box::volume)
      .def_property_readonly("fully_periodic", &Box::fullyPeriodic)
      .def("describe", &Box::describe)
      .def("__repr__", [](const Box& b) { return "polydem.Box(" + b.describe() + ")"; })
      .def(py::self == py::self);
}

}  // namespace

PYBIND11_MODULE(polydem, m) {
  m.doc() = "polydem: DEM soft spheres, event-driven hard spheres, broad phases and jamming analysis (docs/python.md)";
  m.attr("__version__") = POLYDEM_VERSION;
  m.attr("with_hdf5") = static_cast<bool>(POLYDEM_WITH_HDF5);
  m.attr("with_cgal") = static_cast<bool>(POLYDEM_WITH_CGAL);
  bindErrors(m);
  bindBox(m);
  bindDistributions(m);
  bindBroadPhase(m);
  bindIo(m);
  bindSimulation(m);
  bindJamming(m);
  bindAnalysis(m);
}
