#include "mpmpp/data_io.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_data_io(py::module_& m) {
  m.attr("LARGEST_VALUE") = kLargestValue;
  py::enum_<TimeKind>(m, "TimeKind", "How a data file writes its time")
      .value("seconds", TimeKind::Seconds)
      .value("epoch_seconds", TimeKind::EpochSeconds)
      .value("timestamp", TimeKind::Timestamp)
      .value("local_timestamp", TimeKind::LocalTimestamp);
  py::class_<DataRepairs::Gap>(m, "DataGap", "A gap between two rows of a data file")
      .def_readonly("start_s", &DataRepairs::Gap::start_s)
      .def_readonly("end_s", &DataRepairs::Gap::end_s)
      .def_readonly("missing_rows", &DataRepairs::Gap::missing_rows)
      .def_readonly("split", &DataRepairs::Gap::split);
  py::class_<DataRepairs::StatusWords>(
      m, "DataStatusWords", "A historian's status words in a numeric column, read as missing")
      .def_readonly("column", &DataRepairs::StatusWords::column)
      .def_readonly("cells", &DataRepairs::StatusWords::cells)
      .def_readonly("first", &DataRepairs::StatusWords::first);
  py::class_<DataRepairs>(m, "DataRepairs", "What load_data repaired on the way to the sample grid")
      .def_readonly("jitter_snapped", &DataRepairs::jitter_snapped)
      .def_readonly("max_jitter_s", &DataRepairs::max_jitter_s)
      .def_readonly("duplicates_dropped", &DataRepairs::duplicates_dropped)
      .def_readonly("gaps", &DataRepairs::gaps)
      .def_readonly("bad_quality_rows", &DataRepairs::bad_quality_rows)
      .def_readonly("text_columns", &DataRepairs::text_columns)
      .def_readonly("status_words", &DataRepairs::status_words)
      .def_readonly("resample_factor", &DataRepairs::resample_factor)
      .def_readonly("raw_sample_time_s", &DataRepairs::raw_sample_time_s);
  py::class_<DataTable>(m, "DataTable",
                        "A data file's contents (docs/formats.md 'Data file'); NaN = missing")
      .def(py::init(&make_data_table), py::arg("time_s"), py::arg("columns"), py::arg("values"))
      .def_readonly("time_s", &DataTable::time_s)
      .def_readonly("time_origin", &DataTable::time_origin)
      .def_readonly("time_kind", &DataTable::time_kind)
      .def_readonly("origin_epoch_s", &DataTable::origin_epoch_s)
      .def_readonly("utc_offsets", &DataTable::utc_offsets)
      .def_readonly("columns", &DataTable::columns)
      .def_readonly("values", &DataTable::values)
      .def_readonly("missing", &DataTable::missing)
      .def_readonly("text_columns", &DataTable::text_columns)
      .def_readonly("segment_starts", &DataTable::segment_starts)
      .def_readonly("repairs", &DataTable::repairs)
      .def_property_readonly("num_samples", &DataTable::num_samples);
  py::class_<LoadOptions>(m, "LoadOptions",
                          "How load_data puts a historian export on the model's grid")
      .def(py::init([](double max_gap_s, double jitter_fraction, double resample_s,
                       std::string quality_column, std::vector<std::string> good_quality) {
             return LoadOptions{max_gap_s, jitter_fraction, resample_s, std::move(quality_column),
                                std::move(good_quality)};
           }),
           py::arg("max_gap_s") = -1.0, py::arg("jitter_fraction") = 0.25,
           py::arg("resample_s") = 0.0, py::arg("quality_column") = "",
           py::arg("good_quality") = std::vector<std::string>{});
  const auto release = py::call_guard<py::gil_scoped_release>();
  m.def("read_csv", &read_csv, py::arg("path"), release);
  m.def("read_csv_rows", &read_csv_rows, py::arg("path"), release);
  m.def("parse_csv", &parse_csv, py::arg("text"), py::arg("source") = "<string>", release);
  m.def("validate_data", &validate_data, py::arg("data"), py::arg("model"), py::arg("source"),
        release);
  m.def("load_data", &load_data, py::arg("path"), py::arg("model"),
        py::arg("options") = LoadOptions{}, release);
  m.def("load_data_text", &load_data_text, py::arg("text"), py::arg("source"), py::arg("model"),
        py::arg("options") = LoadOptions{}, release);
  m.def("format_time", &format_time, py::arg("data"), py::arg("time_s"));
  m.def("write_csv", &write_csv, py::arg("data"), py::arg("path"), release);
}

}  // namespace mpmpp::bindings
