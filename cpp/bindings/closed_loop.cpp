#include "mpmpp/closed_loop.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_closed_loop(py::module_& m) {
  py::class_<ExtraVariable>(m, "ExtraVariable")
      .def(py::init<>())
      .def_readwrite("name", &ExtraVariable::name)
      .def_readwrite("operating_point", &ExtraVariable::operating_point)
      .def_readwrite("sigma", &ExtraVariable::sigma)
      .def_readwrite("noise", &ExtraVariable::noise);

  py::class_<Plant>(m, "Plant",
                    "the true plant: Box-Jenkins per output, extra variables, actuators")
      .def(py::init<>())
      .def_readwrite("process", &Plant::process)
      .def_readwrite("noise", &Plant::noise)
      .def_readwrite("sigma", &Plant::sigma)
      .def_readwrite("extra", &Plant::extra)
      .def_readwrite("extra_process", &Plant::extra_process)
      .def_readwrite("actuators", &Plant::actuators)
      .def_readwrite("outlier_probability", &Plant::outlier_probability)
      .def_readwrite("outlier_size", &Plant::outlier_size);

  py::enum_<EventKind>(m, "EventKind")
      .value("process", EventKind::Process)
      .value("extra_process", EventKind::ExtraProcess)
      .value("noise", EventKind::Noise)
      .value("sigma", EventKind::Sigma)
      .value("drift", EventKind::Drift)
      .value("actuator", EventKind::Actuator)
      .value("cv_target", EventKind::CvTarget)
      .value("mv_target", EventKind::MvTarget);

  py::class_<Event>(m, "Event")
      .def(py::init<>())
      .def_readwrite("sample", &Event::sample)
      .def_readwrite("kind", &Event::kind)
      .def_readwrite("output", &Event::output)
      .def_readwrite("input", &Event::input)
      .def_readwrite("model", &Event::model)
      .def_readwrite("fresh", &Event::fresh,
                     "process events: the new channel from rest, the old one's response fading "
                     "(default: the new channel replayed over the input history)")
      .def_readwrite("value", &Event::value)
      .def_readwrite("rate", &Event::rate)
      .def_readwrite("actuator", &Event::actuator);

  py::class_<ClosedLoopConfig>(m, "ClosedLoopConfig")
      .def(py::init<>())
      .def_readwrite("model", &ClosedLoopConfig::model, "the nominal model the MPC uses")
      .def_readwrite("tuning", &ClosedLoopConfig::tuning)
      .def_readwrite("pid_loops", &ClosedLoopConfig::pid_loops,
                     "non-empty: multi-loop PID instead of the MPC")
      .def_readwrite("plant", &ClosedLoopConfig::plant)
      .def_readwrite("u_operating", &ClosedLoopConfig::u_operating)
      .def_readwrite("y_operating", &ClosedLoopConfig::y_operating)
      .def_readwrite("num_samples", &ClosedLoopConfig::num_samples)
      .def_readwrite("seed", &ClosedLoopConfig::seed)
      .def_readwrite("events", &ClosedLoopConfig::events)
      .def_readwrite("record_qps", &ClosedLoopConfig::record_qps)
      .def_readwrite("output_disturbance", &ClosedLoopConfig::output_disturbance,
                     "[samples x outputs] added to y; empty = none")
      .def_readwrite("position_noise", &ClosedLoopConfig::position_noise,
                     "[samples x inputs] added to the actuator position; empty = none");

  py::class_<SimulationResult>(m, "SimulationResult")
      .def_readonly("u", &SimulationResult::u)
      .def_readonly("u_actual", &SimulationResult::u_actual)
      .def_readonly("y", &SimulationResult::y)
      .def_readonly("setpoint", &SimulationResult::setpoint)
      .def_readonly("extra", &SimulationResult::extra)
      .def_readonly("failed_solves", &SimulationResult::failed_solves)
      .def_readonly("qp_P", &SimulationResult::qp_P)
      .def_readonly("qp_A", &SimulationResult::qp_A)
      .def_readonly("qp_q", &SimulationResult::qp_q)
      .def_readonly("qp_l", &SimulationResult::qp_l)
      .def_readonly("qp_u", &SimulationResult::qp_u);

  m.def("simulate_closed_loop", &simulate_closed_loop, py::arg("config"),
        py::call_guard<py::gil_scoped_release>(),
        "run a closed-loop simulation (see closed_loop.hpp)");
}

}  // namespace mpmpp::bindings
