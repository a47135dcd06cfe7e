#include "mpmpp/change_scan.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_change_scan(py::module_& m) {
  py::class_<OnsetFit>(m, "OnsetFit", "least-squares fit of r = theta psi after an onset")
      .def_readonly("onset", &OnsetFit::onset)
      .def_readonly("statistic", &OnsetFit::statistic)
      .def_readonly("theta", &OnsetFit::theta)
      .def_readonly("theta_se", &OnsetFit::theta_se)
      .def_readonly("step", &OnsetFit::step)
      .def_readonly("onset_first", &OnsetFit::onset_first)
      .def_readonly("onset_last", &OnsetFit::onset_last);
  m.attr("ONSET_SET_DROP") = kOnsetSetDrop;
  py::class_<CrossValidatedOnset>(m, "CrossValidatedOnset",
                                  "onset scan on all samples and two-fold cross-validated")
      .def_readonly("full", &CrossValidatedOnset::full)
      .def_property_readonly(
          "folds",
          [](const CrossValidatedOnset& c) { return py::make_tuple(c.fold[0], c.fold[1]); })
      .def_property_readonly("heldout", [](const CrossValidatedOnset& c) {
        return py::make_tuple(c.heldout[0], c.heldout[1]);
      });
  py::class_<ArSplit>(m, "ArSplit", "two-segment AR split of a residual")
      .def_readonly("onset", &ArSplit::onset)
      .def_readonly("statistic", &ArSplit::statistic)
      .def_readonly("variance_before", &ArSplit::variance_before)
      .def_readonly("variance_after", &ArSplit::variance_after)
      .def_readonly("variance_all", &ArSplit::variance_all);
  m.def("scan_onset", &scan_onset, py::arg("r"), py::arg("r_without"), py::arg("psi"),
        py::arg("weight"), py::arg("min_segment"), py::arg("step"),
        py::call_guard<py::gil_scoped_release>());
  m.def("scan_onset_cross_validated", &scan_onset_cross_validated, py::arg("r"),
        py::arg("r_without"), py::arg("psi"), py::arg("weight"), py::arg("odd"),
        py::arg("min_segment"), py::arg("step"), py::call_guard<py::gil_scoped_release>());
  py::class_<ProjectedOnsetScan>(m, "ProjectedOnsetScan",
                                 "cross-validated onset scans of candidates fitted beside nuisance "
                                 "columns, for one residual")
      .def(py::init<const Eigen::Ref<const Eigen::VectorXd>&,
                    const Eigen::Ref<const Eigen::VectorXd>&,
                    const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const RowMatrixXd>&,
                    const Eigen::Ref<const RowMatrixXd>&, Eigen::Index, Eigen::Index, Eigen::Index,
                    double>(),
           py::arg("r"), py::arg("weight"), py::arg("odd"), py::arg("columns"), py::arg("solve"),
           py::arg("begin"), py::arg("min_segment"), py::arg("step"),
           py::arg("onset_penalty") = 0.0)
      .def("fit", &ProjectedOnsetScan::fit, py::arg("x"), py::arg("nominal") = py::none(),
           py::arg("weight") = py::none(), py::call_guard<py::gil_scoped_release>())
      .def("fit_holding_scale", &ProjectedOnsetScan::fit_holding_scale, py::arg("x"),
           py::arg("nominal") = py::none(), py::arg("weight") = py::none(), py::arg("scale") = 1.0,
           py::call_guard<py::gil_scoped_release>())
      .def("fit_with_level_step", &ProjectedOnsetScan::fit_with_level_step, py::arg("x"),
           py::arg("level"), py::arg("nominal") = py::none(),
           py::call_guard<py::gil_scoped_release>());
  m.def("fit_at_onset", &fit_at_onset, py::arg("r"), py::arg("r_without"), py::arg("psi"),
        py::arg("weight"), py::arg("onset"));
  m.def("fit_ar", &fit_ar, py::arg("e"), py::arg("order"), py::arg("begin"), py::arg("end"),
        py::arg("span") = 0);
  m.def("ar_residual_variances", &ar_residual_variances, py::arg("e"), py::arg("max_order"),
        py::arg("begin"), py::arg("end"));
  m.def("split_ar", &split_ar, py::arg("e"), py::arg("order"), py::arg("min_segment"),
        py::arg("step"), py::call_guard<py::gil_scoped_release>());
}

}  // namespace mpmpp::bindings
