// Thin bindings of detector training (detector_training.hpp).
#include "mpmpp/detector_training.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_detector_training(py::module_& m) {
  using Ref = Eigen::Ref<const RowMatrixXd>;
  m.def(
      "train_detector",
      py::overload_cast<const Model&, const DetectorConfig&, const WindowFeatures::Series&, double>(
          &train_detector),
      py::arg("model"), py::arg("config"), py::arg("series"), py::arg("train_end_s"),
      py::call_guard<py::gil_scoped_release>());
  m.def("train_detector",
        py::overload_cast<const Model&, const DetectorConfig&,
                          const Eigen::Ref<const Eigen::VectorXd>&,
                          const Eigen::Ref<const Eigen::MatrixXd>&,
                          const Eigen::Ref<const Eigen::MatrixXd>&, double>(&train_detector),
        py::arg("model"), py::arg("config"), py::arg("time_s"), py::arg("u"), py::arg("y"),
        py::arg("train_end_s"), py::call_guard<py::gil_scoped_release>());
  m.def("train_channel_scorer", &train_channel_scorer, py::arg("estimates"), py::arg("config"),
        py::arg("seed"), py::arg("covariances") = Eigen::MatrixXd(), py::arg("noise") = false,
        py::arg("mean_ratio") = 0.0, py::call_guard<py::gil_scoped_release>());
  m.def(
      "draw_training_models",
      [](const Ref& estimates, const DetectorConfig& config, std::uint64_t seed,
         const Eigen::MatrixXd& reference_covariance, bool noise) {
        ResampledModels r =
            draw_training_models(estimates, config, seed, reference_covariance, noise);
        return py::make_tuple(std::move(r.models), r.correlated);
      },
      py::arg("estimates"), py::arg("config"), py::arg("seed"),
      py::arg("reference_covariance") = Eigen::MatrixXd(), py::arg("noise") = false,
      "-> (models, correlated)");
  m.def("mean_variance_ratio", &mean_variance_ratio, py::arg("firsts"), py::arg("window"));
  m.def("directional_max", &directional_max, py::arg("A"), py::arg("B"));
  m.def("channel_seed", &channel_seed, py::arg("seed"), py::arg("channel"));
  m.def("outlier_offset", &outlier_offset, py::arg("scores"), py::arg("fraction"));

  py::class_<OutlierFractionCv>(m, "OutlierFractionCv", "Cross-validated outlier fraction")
      .def_readonly("fractions", &OutlierFractionCv::fractions)
      .def_readonly("accuracy", &OutlierFractionCv::accuracy)
      .def_readonly("outlier_fraction", &OutlierFractionCv::outlier_fraction)
      .def_readonly("validation_accuracy", &OutlierFractionCv::validation_accuracy)
      .def_readonly("n_folds", &OutlierFractionCv::n_folds)
      .def_readonly("order", &OutlierFractionCv::order);
  m.def(
      "cross_validate_outlier_fraction",
      [](const Ref& X, const std::vector<double>& fractions, int n_folds, std::uint64_t seed,
         double nu, double kernel_scale, double tol, double cache_mb, bool shrinking,
         std::int64_t max_iter) {
        return cross_validate_outlier_fraction(
            X, fractions, n_folds, seed,
            svm_options(nu, kernel_scale, tol, cache_mb, shrinking, max_iter));
      },
      py::arg("X"), py::arg("fractions"), py::arg("n_folds"), py::arg("seed"), py::arg("nu") = 0.5,
      py::arg("kernel_scale") = 1.0, py::arg("tol") = 1e-3, py::arg("cache_mb") = 200.0,
      py::arg("shrinking") = true, py::arg("max_iter") = -1,
      py::call_guard<py::gil_scoped_release>());
}

}  // namespace mpmpp::bindings
