#include "mpmpp/data_io.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_data_io(py::module_& m) {
  py::class_<DataTable>(m, "DataTable", "A data file's contents (FORMATS.md 'Data file'); NaN = missing")
      .def(py::init(&make_data_table), py::arg("time_s"), py::arg("columns"), py::arg("values"))
      .def_readonly("time_s", &DataTable::time_s)
      .def_readonly("time_origin", &DataTable::time_origin)
      .def_readonly("columns", &DataTable::columns)
      .def_readonly("values", &DataTable::values)
      .def_readonly("missing", &DataTable::missing)
      .def_property_readonly("num_samples", &DataTable::num_samples);
  const auto release = py::call_guard<py::gil_scoped_release>();
  m.def("read_csv", &read_csv, py::arg("path"), release);
  m.def("parse_csv", &parse_csv, py::arg("text"), py::arg("source") = "<string>", release);
  m.def("validate_data", &validate_data, py::arg("data"), py::arg("model"), py::arg("source"), release);
  m.def("load_data", &load_data, py::arg("path"), py::arg("model"), release);
  m.def("write_csv", &write_csv, py::arg("data"), py::arg("path"), release);
}

}  // namespace mpmpp::bindings
