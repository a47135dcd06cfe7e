#include "mpmpp/refitted_noise.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_refitted_noise(py::module_& m) {
  py::class_<OnsetGains>(m, "OnsetGains",
                         "per onset and training fold: in-fold and held-out statistics of a "
                         "candidate with the AR correction refitted")
      .def_readonly("in_fold", &OnsetGains::in_fold)
      .def_readonly("held_out", &OnsetGains::held_out);
  py::class_<RefittedNoise>(m, "RefittedNoise",
                            "scores candidate terms in one output's one-step error with the AR "
                            "noise correction refitted for each, at every onset of a grid")
      .def(py::init<
               const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>&,
               const Eigen::Ref<const Eigen::VectorXd>&, const std::vector<Eigen::Index>&, int>(),
           py::arg("e"), py::arg("fold0"), py::arg("fold1"), py::arg("onsets"), py::arg("order"))
      .def("gains", &RefittedNoise::gains, py::arg("psi"),
           py::call_guard<py::gil_scoped_release>());
}

}  // namespace mpmpp::bindings
