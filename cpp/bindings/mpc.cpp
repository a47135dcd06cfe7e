#include "mpmpp/mpc.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "mpmpp/error.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

using ProcessMatrix = std::vector<std::vector<std::optional<TransferFunction>>>;

// The nominal Model from Python pieces (the Model struct itself is bound by model IO).
Model make_model(const ProcessMatrix& process, const std::vector<TransferFunction>& noise,
                 std::vector<std::string> inputs, std::vector<std::string> outputs, double sample_time_s) {
  Model m;
  m.sample_time_s = sample_time_s;
  m.process = process;
  const size_t ny = process.size(), nu = ny ? process[0].size() : 0;
  for (const auto& row : process)
    if (row.size() != nu) throw InputError("process must be a rectangular [output][input] matrix");
  if (inputs.empty())
    for (size_t j = 0; j < nu; ++j) inputs.push_back("u" + std::to_string(j + 1));
  if (outputs.empty())
    for (size_t i = 0; i < ny; ++i) outputs.push_back("y" + std::to_string(i + 1));
  if (inputs.size() != nu || outputs.size() != ny)
    throw InputError("inputs/outputs names must match the process matrix shape");
  m.inputs = std::move(inputs);
  m.outputs = std::move(outputs);
  m.noise = noise.empty() ? std::vector<TransferFunction>(ny) : noise;
  if (m.noise.size() != ny) throw InputError("noise must have one model per output");
  return m;
}

void bind_mpc(py::module_& m) {
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
      .def_readwrite("mv_soft_max", &MpcTuning::mv_soft_max);

  py::class_<Mpc>(m, "Mpc", "Linear MPC on a nominal transfer-matrix model (see mpc.hpp)")
      .def(py::init([](const ProcessMatrix& process, const MpcTuning& tuning, const Eigen::VectorXd& u_initial) {
             return Mpc(make_model(process, {}, {}, {}, 1.0), tuning, u_initial);
           }),
           py::arg("process"), py::arg("tuning"), py::arg("u_initial"))
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
      .def_property_readonly("status", [](const Mpc& c) { return std::string(to_string(c.last_result().status)); })
      .def_property_readonly("dynamic_matrix", &Mpc::dynamic_matrix)
      .def_property_readonly("free_response", &Mpc::free_response)
      .def_property_readonly("disturbance_estimate", &Mpc::disturbance_estimate)
      .def_property_readonly("num_variables", &Mpc::num_variables)
      .def_property_readonly("failed_solves", &Mpc::failed_solves);
}

}  // namespace mpmpp::bindings
