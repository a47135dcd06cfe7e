#pragma once
// One binding file per concept; module.cpp calls each in dependency order.
#include <pybind11/pybind11.h>

#include <cstdint>

#include "mpmpp/one_class_svm.hpp"

namespace mpmpp::bindings {
void bind_transfer_function(pybind11::module_& m);
void bind_model_io(pybind11::module_& m);
void bind_data_io(pybind11::module_& m);
void bind_qp(pybind11::module_& m);
void bind_identification(pybind11::module_& m);
void bind_prediction(pybind11::module_& m);
void bind_residual_analysis(pybind11::module_& m);
void bind_change_scan(pybind11::module_& m);
void bind_refitted_noise(pybind11::module_& m);
void bind_one_class_svm(pybind11::module_& m);
void bind_mpc(pybind11::module_& m);
void bind_actuator(pybind11::module_& m);
void bind_pid_controller(pybind11::module_& m);
void bind_closed_loop(pybind11::module_& m);
void bind_detector(pybind11::module_& m);
void bind_detector_training(pybind11::module_& m);
void bind_detector_io(pybind11::module_& m);
void bind_streaming_detector(pybind11::module_& m);

// The solver options from the keyword arguments the SVM functions share.
OneClassSvmOptions svm_options(double nu, double kernel_scale, double tol, double cache_mb,
                               bool shrinking, std::int64_t max_iter);
}  // namespace mpmpp::bindings
