#include "mpmpp/mpc.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

void bind_mpc(py::module_& m) {
  py::enum_<DisturbanceModel>(m, "DisturbanceModel",
                              "output-disturbance forecast of the MPC (see mpc.hpp)")
      .value("bias", DisturbanceModel::Bias)
      .value("noise_model", DisturbanceModel::NoiseModel);

  py::class_<MpcTuning>(m, "MpcTuning", "MPC horizons, weights and limits (see mpc.hpp)")
      .def(py::init<>())
      .def_readwrite("prediction_horizon", &MpcTuning::prediction_horizon)
      .def_readwrite("control_horizon", &MpcTuning::control_horizon)
      .def_readwrite("cv_target", &MpcTuning::cv_target)
      .def_readwrite("mv_target", &MpcTuning::mv_target)
      .def_readwrite("cv_target_weight", &MpcTuning::cv_target_weight)
      .def_readwrite("mv_target_weight", &MpcTuning::mv_target_weight)
      .def_readwrite("move_weight", &MpcTuning::move_weight)
      .def_readwrite("deviation_weight", &MpcTuning::deviation_weight)
      .def_readwrite("cv_minmax_weight", &MpcTuning::cv_minmax_weight)
      .def_readwrite("mv_minmax_weight", &MpcTuning::mv_minmax_weight)
      .def_readwrite("mv_min", &MpcTuning::mv_min)
      .def_readwrite("mv_max", &MpcTuning::mv_max)
      .def_readwrite("mv_max_move", &MpcTuning::mv_max_move)
      .def_readwrite("cv_min", &MpcTuning::cv_min)
      .def_readwrite("cv_max", &MpcTuning::cv_max)
      .def_readwrite("cv_max_move", &MpcTuning::cv_max_move)
      .def_readwrite("mv_soft_min", &MpcTuning::mv_soft_min)
      .def_readwrite("mv_soft_max", &MpcTuning::mv_soft_max)
      .def_readwrite("disturbance", &MpcTuning::disturbance)
      .def_readwrite("clip_moves", &MpcTuning::clip_moves);

  py::class_<Mpc>(m, "Mpc", "Linear MPC on a nominal transfer-matrix model (see mpc.hpp)")
      .def(py::init<const Model&, MpcTuning, const Eigen::Ref<const Eigen::VectorXd>&>(),
           py::arg("model"), py::arg("tuning"), py::arg("u_initial"))
      .def("step", &Mpc::step, py::arg("y"), "measured y(t) -> applied u(t)")
      .def("set_cv_target", &Mpc::set_cv_target, py::arg("output"), py::arg("value"))
      .def("set_mv_target", &Mpc::set_mv_target, py::arg("input"), py::arg("value"))
      .def_property_readonly("u", &Mpc::u)
      .def_property_readonly("prediction_start", &Mpc::prediction_start)
      .def_property_readonly("P", &Mpc::qp_P)
      .def_property_readonly("A", &Mpc::qp_A)
      .def_property_readonly("q", &Mpc::qp_q)
      .def_property_readonly("l", &Mpc::qp_l)
      .def_property_readonly("u_bound", &Mpc::qp_u)
      .def_property_readonly("x", [](const Mpc& c) { return c.last_result().x; })
      .def_property_readonly(
          "status", [](const Mpc& c) { return std::string(to_string(c.last_result().status)); })
      .def_property_readonly("dynamic_matrix", &Mpc::dynamic_matrix)
      .def_property_readonly("free_response", &Mpc::free_response)
      .def_property_readonly("disturbance_estimate", &Mpc::disturbance_estimate)
      .def_property_readonly("num_variables", &Mpc::num_variables)
      .def_property_readonly("failed_solves", &Mpc::failed_solves);
}

}  // namespace mpmpp::bindings
