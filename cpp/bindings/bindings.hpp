#pragma once
// One binding file per concept; module.cpp calls each in dependency order.
#include <pybind11/pybind11.h>

namespace mpmpp::bindings {
void bind_transfer_function(pybind11::module_& m);
void bind_model_io(pybind11::module_& m);
void bind_data_io(pybind11::module_& m);
void bind_qp(pybind11::module_& m);
void bind_identification(pybind11::module_& m);
void bind_prediction(pybind11::module_& m);
void bind_residual_analysis(pybind11::module_& m);
void bind_change_scan(pybind11::module_& m);
void bind_one_class_svm(pybind11::module_& m);
void bind_mpc(pybind11::module_& m);
void bind_closed_loop(pybind11::module_& m);
void bind_detector(pybind11::module_& m);
void bind_streaming_detector(pybind11::module_& m);
void bind_valve(pybind11::module_& m);
}  // namespace mpmpp::bindings
