#include "mpmpp/actuator.hpp"

#include <pybind11/eigen.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_actuator(py::module_& m) {
  py::class_<ActuatorNonlinearity>(m, "ActuatorNonlinearity",
                                   "stiction (S, J), deadband, backlash, saturation (see actuator.hpp)")
      .def(py::init<>())
      .def_readwrite("stiction_s", &ActuatorNonlinearity::stiction_s)
      .def_readwrite("stiction_j", &ActuatorNonlinearity::stiction_j)
      .def_readwrite("deadband", &ActuatorNonlinearity::deadband)
      .def_readwrite("backlash", &ActuatorNonlinearity::backlash)
      .def_readwrite("min", &ActuatorNonlinearity::min)
      .def_readwrite("max", &ActuatorNonlinearity::max);
  m.def("actuator_positions", &actuator_positions, py::arg("commands"), py::arg("nonlinearity"), py::arg("u0"),
        "actuator positions for a command sequence, starting at rest at u0");
}

}  // namespace mpmpp::bindings
