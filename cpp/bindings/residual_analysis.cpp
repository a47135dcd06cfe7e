#include "mpmpp/residual_analysis.hpp"

#include <pybind11/eigen.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_residual_analysis(py::module_& m) {
  m.def(
      "cross_correlation", &cross_correlation, py::arg("x"), py::arg("y"), py::arg("max_lag"),
      "normalised r_xy(tau) = sum x(t) y(t-tau) / sqrt(sum x^2 sum y^2), tau = -max_lag..max_lag");
  m.def("correlation_bound", &correlation_bound, py::arg("r_xx"), py::arg("r_yy"),
        py::arg("n_samples"), py::arg("z"), "Bartlett band half-width z sqrt(sum r_xx r_yy / N)");
  m.def("fit_percent", &fit_percent, py::arg("measured"), py::arg("predicted"),
        "100 (1 - ||y - yhat|| / ||y - mean y||)");
  m.def("windowed_fit", &windowed_fit, py::arg("measured"), py::arg("predicted"), py::arg("window"),
        py::arg("step"), "fit % in moving windows: rows (start index, fit %)");
}

}  // namespace mpmpp::bindings
