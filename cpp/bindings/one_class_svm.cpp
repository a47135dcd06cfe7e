#include "mpmpp/one_class_svm.hpp"

#include <pybind11/eigen.h>

#include "bindings.hpp"
#include "mpmpp/resampling.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

OneClassSvmOptions svm_options(double nu, double kernel_scale, double tol, double cache_mb,
                               bool shrinking, std::int64_t max_iter) {
  OneClassSvmOptions o;
  o.nu = nu;
  o.kernel_scale = kernel_scale;
  o.tol = tol;
  o.cache_mb = cache_mb;
  o.shrinking = shrinking;
  o.max_iter = max_iter;
  return o;
}

void bind_one_class_svm(py::module_& m) {
  using Ref = Eigen::Ref<const RowMatrixXd>;
  py::class_<OneClassSvmModel>(m, "OneClassSvmModel",
                               "Solution of the nu-one-class SVM dual in libsvm scaling")
      .def_readonly("support_vectors", &OneClassSvmModel::support_vectors)
      .def_readonly("support", &OneClassSvmModel::support)
      .def_readonly("dual_coef", &OneClassSvmModel::dual_coef)
      .def_readonly("rho", &OneClassSvmModel::rho)
      .def_readonly("kernel_scale", &OneClassSvmModel::kernel_scale)
      .def_readonly("nu", &OneClassSvmModel::nu)
      .def_readonly("n_train", &OneClassSvmModel::n_train)
      .def_readonly("iterations", &OneClassSvmModel::iterations)
      .def_readonly("converged", &OneClassSvmModel::converged)
      .def_readonly("objective", &OneClassSvmModel::objective)
      .def("paper_scale", &OneClassSvmModel::paper_scale)
      .def("decision_function", &OneClassSvmModel::decision_function, py::arg("X"),
           py::call_guard<py::gil_scoped_release>());

  m.def(
      "fit_one_class_svm",
      [](const Ref& X, double nu, double kernel_scale, double tol, double cache_mb, bool shrinking,
         std::int64_t max_iter) {
        return fit_one_class_svm(X,
                                 svm_options(nu, kernel_scale, tol, cache_mb, shrinking, max_iter));
      },
      py::arg("X"), py::arg("nu") = 0.5, py::arg("kernel_scale") = 1.0, py::arg("tol") = 1e-3,
      py::arg("cache_mb") = 200.0, py::arg("shrinking") = true, py::arg("max_iter") = -1,
      py::call_guard<py::gil_scoped_release>());
  m.def("gaussian_kernel_expansion", &gaussian_kernel_expansion, py::arg("support_vectors"),
        py::arg("coef"), py::arg("kernel_scale"), py::arg("X"), py::arg("n_threads") = 1,
        py::call_guard<py::gil_scoped_release>());

  m.def(
      "coefficient_statistics",
      [](const Ref& features) {
        const CoefficientStatistics s = coefficient_statistics(features);
        return py::make_tuple(s.mean, s.std);
      },
      py::arg("features"));
  m.def("draw_gaussian_models", &draw_gaussian_models, py::arg("mean"), py::arg("std"),
        py::arg("n"), py::arg("alpha"), py::arg("seed"), py::call_guard<py::gil_scoped_release>());
  m.def("coefficient_covariance", &coefficient_covariance, py::arg("features"));
  m.def("draw_correlated_gaussian_models", &draw_correlated_gaussian_models, py::arg("mean"),
        py::arg("covariance"), py::arg("n"), py::arg("alpha"), py::arg("seed"),
        py::call_guard<py::gil_scoped_release>());
  m.def("resample", &resample, py::arg("features"), py::arg("n"), py::arg("alpha") = 1.5,
        py::arg("seed") = 0, py::arg("correlated") = false,
        py::call_guard<py::gil_scoped_release>());
}

}  // namespace mpmpp::bindings
