#pragma once
// Output prediction with a model row (the channels G_i1..G_inu of one output) and its
// noise model H_i. All signals are deviations from an operating point (the caller removes
// means): the model file's transfer functions act on deviations.
//
//   simulation:           yhat_sim(t)  = sum_j G_j(q) u_j(t)
//   k-step-ahead:         yhat(t|t-k)  = W_k G u + (1 - W_k) y,   W_k = Hbar_k H^-1
// with Hbar_k the first k impulse-response terms of H (Ljung, System Identification,
// eq. 3.31). The k-step error is therefore y - yhat(t|t-k) = W_k (y - G u); k = 1 gives the
// innovations H^-1 (y - G u), k -> infinity the simulation error.
#include <Eigen/Dense>
#include <optional>
#include <vector>

#include "mpmpp/transfer_function.hpp"

namespace mpmpp {

using ModelRow = std::vector<std::optional<TransferFunction>>;  // absent channel = zero

// W_k = Hbar_k H^-1 for a monic noise model H (InputError if k < 1 or H not monic).
TransferFunction predictor_weight(const TransferFunction& noise, int horizon);

// sum_j G_j u_j; inputs is N x nu with one column per entry of row.
Eigen::VectorXd simulate_output(const ModelRow& row,
                                const Eigen::Ref<const Eigen::MatrixXd>& inputs);

// Output error v = y - sum_j G_j u_j (the residual of the simulation).
Eigen::VectorXd output_error(const ModelRow& row, const Eigen::Ref<const Eigen::VectorXd>& output,
                             const Eigen::Ref<const Eigen::MatrixXd>& inputs);

// k-step-ahead prediction yhat(t|t-k); horizon 0 means pure simulation.
Eigen::VectorXd predict_output(const ModelRow& row, const TransferFunction& noise,
                               const Eigen::Ref<const Eigen::VectorXd>& output,
                               const Eigen::Ref<const Eigen::MatrixXd>& inputs, int horizon);

// One-step prediction errors (innovations estimate) e = H^-1 (y - G u).
Eigen::VectorXd prediction_error(const ModelRow& row, const TransferFunction& noise,
                                 const Eigen::Ref<const Eigen::VectorXd>& output,
                                 const Eigen::Ref<const Eigen::MatrixXd>& inputs);

}  // namespace mpmpp
