// Thin bindings of the streaming detector: mostly for tests and notebooks; plants
// link the C++ library directly.
#include "mpmpp/streaming_detector.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_streaming_detector(py::module_& m) {
  py::class_<StreamWindow>(m, "StreamWindow",
                           "One completed moving window (see streaming_detector.hpp)")
      .def_readonly("window", &StreamWindow::window)
      .def_readonly("start_s", &StreamWindow::start_s)
      .def_readonly("end_s", &StreamWindow::end_s)
      .def_readonly("training", &StreamWindow::training)
      .def_readonly("skipped", &StreamWindow::skipped)
      .def_readonly("skip_reason", &StreamWindow::skip_reason)
      .def_readonly("scores", &StreamWindow::scores)
      .def_readonly("indicator", &StreamWindow::indicator)
      .def_readonly("alarm", &StreamWindow::alarm)
      .def_readonly("alarm_starts", &StreamWindow::alarm_starts);

  using Vec = Eigen::Ref<const Eigen::VectorXd>;
  py::class_<StreamingDetector>(
      m, "StreamingDetector",
      "Sample-by-sample MPM / noise-change monitoring with a trained Detector")
      .def(py::init<Detector>(), py::arg("detector"))
      .def_static("load", &StreamingDetector::load, py::arg("detector_path"))
      .def(
          "push",
          [](StreamingDetector& s, double t, const Vec& u, const Vec& y) -> py::object {
            StreamWindow w;
            bool done;
            {
              py::gil_scoped_release release;
              done = s.push(t, u, y, w);
            }
            return done ? py::cast(std::move(w)) : py::none();
          },
          py::arg("time_s"), py::arg("u"), py::arg("y"),
          "One sample; the completed StreamWindow, or None")
      .def("push_block", &StreamingDetector::push_block, py::arg("time_s"), py::arg("u"),
           py::arg("y"), py::call_guard<py::gil_scoped_release>())
      .def("checkpoint_json", &StreamingDetector::checkpoint_json)
      .def("save_checkpoint", &StreamingDetector::save_checkpoint, py::arg("path"),
           py::call_guard<py::gil_scoped_release>())
      .def("restore_checkpoint_json", &StreamingDetector::restore_checkpoint_json, py::arg("text"),
           py::arg("source") = "<string>")
      .def("load_checkpoint", &StreamingDetector::load_checkpoint, py::arg("path"),
           py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("detector", &StreamingDetector::detector)
      .def_property_readonly("samples", &StreamingDetector::samples)
      .def_property_readonly("windows", &StreamingDetector::windows)
      .def_property_readonly("window_samples", &StreamingDetector::window_samples)
      .def_property_readonly("step_samples", &StreamingDetector::step_samples)
      .def_property_readonly("alarm", &StreamingDetector::alarm);
}

}  // namespace mpmpp::bindings
