// Thin bindings of the detection-result writers (detector_io.hpp) and the channel label.
#include "mpmpp/detector_io.hpp"

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_detector_io(py::module_& m) {
  m.def("detection_json", &detection_json, py::arg("detector"), py::arg("result"),
        py::arg("indent") = -1);
  m.def("detection_alarms_csv", &detection_alarms_csv, py::arg("detector"), py::arg("result"));
  m.def("detection_scores_csv", &detection_scores_csv, py::arg("detector"), py::arg("result"));
  m.def("save_detection_json", &save_detection_json, py::arg("path"), py::arg("detector"),
        py::arg("result"), py::arg("indent") = 1);
  m.def("save_detection_alarms_csv", &save_detection_alarms_csv, py::arg("path"),
        py::arg("detector"), py::arg("result"));
  m.def("save_detection_scores_csv", &save_detection_scores_csv, py::arg("path"),
        py::arg("detector"), py::arg("result"));
  m.def("channel_label", py::overload_cast<const std::string&, const std::string&>(&channel_label),
        py::arg("output"), py::arg("input") = "",
        "G[output <- input], or H[output] for a noise channel (input empty)");
}

}  // namespace mpmpp::bindings
