#include "mpmpp/pid_controller.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_pid_controller(py::module_& m) {
  py::class_<PidLoop>(
      m, "PidLoop", "one PID loop: output <- input, K, Ti, Td, N, saturation (pid_controller.hpp)")
      .def(py::init<>())
      .def_readwrite("output", &PidLoop::output)
      .def_readwrite("input", &PidLoop::input)
      .def_readwrite("gain", &PidLoop::gain)
      .def_readwrite("integral_time_s", &PidLoop::integral_time_s)
      .def_readwrite("derivative_time_s", &PidLoop::derivative_time_s)
      .def_readwrite("derivative_filter", &PidLoop::derivative_filter)
      .def_readwrite("min", &PidLoop::min)
      .def_readwrite("max", &PidLoop::max);
  m.def("pid_outputs", &pid_outputs, py::arg("loops"), py::arg("sample_time_s"),
        py::arg("u_initial"), py::arg("y"), py::arg("setpoint"),
        "controller outputs u (samples x inputs) for measurements y and setpoints");
}

}  // namespace mpmpp::bindings
