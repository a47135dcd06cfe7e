#include "mpmpp/transfer_function.hpp"

#include <pybind11/eigen.h>
#include <pybind11/operators.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_transfer_function(py::module_& m) {
  py::class_<TransferFunction>(
      m, "TransferFunction", "G(q) = q^-delay num(q^-1) / den(q^-1), den normalised to den[0] = 1")
      .def(py::init<>())
      .def(py::init<Eigen::VectorXd, Eigen::VectorXd, int>(), py::arg("num"), py::arg("den"),
           py::arg("delay") = 0)
      .def_static("from_foptd", &TransferFunction::from_foptd, py::arg("gain"),
                  py::arg("time_constant_s"), py::arg("dead_time_s"), py::arg("sample_time_s"))
      .def_property_readonly("num", &TransferFunction::num)
      .def_property_readonly("den", &TransferFunction::den)
      .def_property_readonly("delay", &TransferFunction::delay)
      .def(
          "filter",
          [](const TransferFunction& g, const Eigen::Ref<const Eigen::VectorXd>& x,
             const std::vector<Eigen::Index>& stretch_starts) {
            if (stretch_starts.empty()) return g.filter(x);
            // A record of several stretches laid end to end: each filtered from rest.
            std::vector<detail::RowSpan> spans;
            detail::stretch_spans(x.size(), stretch_starts, spans);
            Eigen::VectorXd out(x.size());
            filter_into(g.num(), g.den(), g.delay(), spans, x, out);
            return out;
          },
          py::arg("x"), py::arg("stretch_starts") = std::vector<Eigen::Index>{},
          "G x from rest; with stretch_starts (rows where a new stretch of a record with gaps "
          "begins) each stretch from rest")
      .def("impulse", &TransferFunction::impulse, py::arg("n"))
      .def("step", &TransferFunction::step, py::arg("n"))
      .def("dc_gain", &TransferFunction::dc_gain)
      .def("poles", &TransferFunction::poles)
      .def("zeros", &TransferFunction::zeros)
      .def("is_stable", &TransferFunction::is_stable)
      .def("is_minimum_phase", &TransferFunction::is_minimum_phase)
      .def("is_zero", &TransferFunction::is_zero, "numerator identically zero")
      .def("series", &TransferFunction::series)
      .def("parallel", &TransferFunction::parallel)
      .def("inverse", &TransferFunction::inverse)
      .def(py::self == py::self)
      .def("__str__", [](const TransferFunction& g) { return to_string(g); })
      .def("__repr__", [](const TransferFunction& g) {
        return "TransferFunction(num=" + py::repr(py::cast(g.num())).cast<std::string>() +
               ", den=" + py::repr(py::cast(g.den())).cast<std::string>() +
               ", delay=" + std::to_string(g.delay()) + ")";
      });
}

}  // namespace mpmpp::bindings
