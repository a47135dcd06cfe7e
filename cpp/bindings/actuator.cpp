#include "mpmpp/actuator.hpp"

#include <pybind11/eigen.h>

#include <cmath>
#include <limits>

#include "bindings.hpp"
#include "mpmpp/error.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_actuator(py::module_& m) {
  py::enum_<StictionLaw>(m, "StictionLaw")
      .value("choudhury", StictionLaw::Choudhury)
      .value("he", StictionLaw::He);
  py::class_<ActuatorNonlinearity>(
      m, "ActuatorNonlinearity",
      "stiction (S, J; Choudhury or He law), deadband, backlash, saturation (see actuator.hpp)")
      .def(py::init([](StictionLaw law, double s, double j, double deadband, double backlash,
                       double min, double max) {
             return ActuatorNonlinearity{law, s, j, deadband, backlash, min, max};
           }),
           py::kw_only(), py::arg("stiction_law") = StictionLaw::Choudhury,
           py::arg("stiction_s") = 0.0, py::arg("stiction_j") = 0.0, py::arg("deadband") = 0.0,
           py::arg("backlash") = 0.0, py::arg("min") = -std::numeric_limits<double>::infinity(),
           py::arg("max") = std::numeric_limits<double>::infinity())
      .def_readwrite("stiction_law", &ActuatorNonlinearity::stiction_law)
      .def_readwrite("stiction_s", &ActuatorNonlinearity::stiction_s)
      .def_readwrite("stiction_j", &ActuatorNonlinearity::stiction_j)
      .def_readwrite("deadband", &ActuatorNonlinearity::deadband)
      .def_readwrite("backlash", &ActuatorNonlinearity::backlash)
      .def_readwrite("min", &ActuatorNonlinearity::min)
      .def_readwrite("max", &ActuatorNonlinearity::max);
  py::class_<Actuator>(m, "Actuator", "an actuator stepped sample by sample, at rest at u0")
      .def(py::init<const ActuatorNonlinearity&, double>(), py::arg("nonlinearity"), py::arg("u0"))
      .def(
          "move",
          [](Actuator& a, double command) {
            if (!std::isfinite(command)) throw InputError("actuator command must be finite");
            return a.move(command);
          },
          py::arg("command"), "position for the next command sample");
  m.def("actuator_positions", &actuator_positions, py::arg("commands"), py::arg("nonlinearity"),
        py::arg("u0"), "actuator positions for a command sequence, starting at rest at u0");
}

}  // namespace mpmpp::bindings
