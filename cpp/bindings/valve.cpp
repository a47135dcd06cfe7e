#include "mpmpp/valve.hpp"

#include <pybind11/eigen.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_valve(py::module_& m) {
  py::enum_<ValveKind>(m, "ValveKind")
      .value("linear", ValveKind::Linear)
      .value("stick_slip", ValveKind::StickSlip)
      .value("he", ValveKind::He)
      .value("backlash", ValveKind::Backlash)
      .value("deadband", ValveKind::Deadband)
      .value("saturation", ValveKind::Saturation);
  py::class_<Valve>(m, "Valve", "control-valve model: OP -> valve position (OP units)")
      .def(py::init<ValveKind, double, double>(), py::arg("kind"), py::arg("a") = 0.0,
           py::arg("b") = 0.0)
      .def("step", &Valve::step, py::arg("op"), "position for the next OP sample")
      .def("reset", &Valve::reset)
      .def("apply", &Valve::apply, py::arg("op"), "positions for an OP sequence from a reset valve")
      .def_property_readonly("kind", &Valve::kind);
}

}  // namespace mpmpp::bindings
