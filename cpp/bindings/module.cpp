#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "mpmpp C++/Eigen engine";
  m.attr("__version__") = MPMPP_VERSION;
  mpmpp::bindings::bind_transfer_function(m);
  mpmpp::bindings::bind_model_io(m);
  mpmpp::bindings::bind_data_io(m);
  mpmpp::bindings::bind_qp(m);
  mpmpp::bindings::bind_identification(m);
  mpmpp::bindings::bind_prediction(m);
  mpmpp::bindings::bind_residual_analysis(m);
  mpmpp::bindings::bind_change_scan(m);
  mpmpp::bindings::bind_refitted_noise(m);
  mpmpp::bindings::bind_one_class_svm(m);
  mpmpp::bindings::bind_mpc(m);
  mpmpp::bindings::bind_actuator(m);
  mpmpp::bindings::bind_pid_controller(m);
  mpmpp::bindings::bind_closed_loop(m);
  mpmpp::bindings::bind_detector(m);
  mpmpp::bindings::bind_detector_training(m);
  mpmpp::bindings::bind_detector_io(m);
  mpmpp::bindings::bind_streaming_detector(m);
}
