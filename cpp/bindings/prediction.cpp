#include "mpmpp/prediction.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_prediction(py::module_& m) {
  // `row` is a list with one TransferFunction or None (absent channel) per input column.
  m.def("predictor_weight", &predictor_weight, py::arg("noise"), py::arg("horizon"),
        "W_k = Hbar_k H^-1 of the k-step-ahead predictor");
  m.def("simulate_output", &simulate_output, py::arg("row"), py::arg("inputs"),
        "sum_j G_j u_j for one output (inputs N x nu, deviations)");
  m.def("output_error", &output_error, py::arg("row"), py::arg("output"), py::arg("inputs"),
        "v = y - sum_j G_j u_j");
  m.def("predict_output", &predict_output, py::arg("row"), py::arg("noise"), py::arg("output"),
        py::arg("inputs"), py::arg("horizon"),
        "k-step-ahead prediction W_k G u + (1 - W_k) y; horizon 0 = simulation",
        py::call_guard<py::gil_scoped_release>());
  m.def("prediction_error", &prediction_error, py::arg("row"), py::arg("noise"), py::arg("output"),
        py::arg("inputs"), "one-step prediction errors H^-1 (y - G u)",
        py::call_guard<py::gil_scoped_release>());
}

}  // namespace mpmpp::bindings
