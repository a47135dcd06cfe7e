#include "mpmpp/prediction.hpp"

#include <cmath>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

void check_shapes(const ModelRow& row, Eigen::Index n_rows, Eigen::Index n_cols,
                  Eigen::Index n_output) {
  if (static_cast<Eigen::Index>(row.size()) != n_cols)
    throw InputError("inputs has " + std::to_string(n_cols) + " columns but the model row has " +
                     std::to_string(row.size()) + " channels");
  if (n_output >= 0 && n_output != n_rows)
    throw InputError("output has " + std::to_string(n_output) + " samples but inputs has " +
                     std::to_string(n_rows));
}

}  // namespace

TransferFunction predictor_weight(const TransferFunction& noise, int horizon) {
  if (horizon < 1) throw InputError("horizon must be >= 1, got " + std::to_string(horizon));
  if (noise.delay() != 0 || std::abs(noise.num()[0] - 1.0) > 1e-12)
    throw InputError("noise model must be monic (num[0] == den[0], no delay)");
  // Hbar_k is a polynomial (FIR); W_k = Hbar_k * den_H / num_H.
  const Eigen::VectorXd hbar = noise.impulse(horizon);
  return TransferFunction(poly_multiply(hbar, noise.den()), noise.num(), 0);
}

Eigen::VectorXd simulate_output(const ModelRow& row,
                                const Eigen::Ref<const Eigen::MatrixXd>& inputs) {
  check_shapes(row, inputs.rows(), inputs.cols(), -1);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(inputs.rows());
  for (std::size_t j = 0; j < row.size(); ++j)
    if (row[j]) y += row[j]->filter(inputs.col(static_cast<Eigen::Index>(j)));
  return y;
}

Eigen::VectorXd output_error(const ModelRow& row, const Eigen::Ref<const Eigen::VectorXd>& output,
                             const Eigen::Ref<const Eigen::MatrixXd>& inputs) {
  check_shapes(row, inputs.rows(), inputs.cols(), output.size());
  return output - simulate_output(row, inputs);
}

Eigen::VectorXd predict_output(const ModelRow& row, const TransferFunction& noise,
                               const Eigen::Ref<const Eigen::VectorXd>& output,
                               const Eigen::Ref<const Eigen::MatrixXd>& inputs, int horizon) {
  if (horizon < 0) throw InputError("horizon must be >= 0, got " + std::to_string(horizon));
  const Eigen::VectorXd v = output_error(row, output, inputs);
  if (horizon == 0) return output - v;
  return output - predictor_weight(noise, horizon).filter(v);
}

Eigen::VectorXd prediction_error(const ModelRow& row, const TransferFunction& noise,
                                 const Eigen::Ref<const Eigen::VectorXd>& output,
                                 const Eigen::Ref<const Eigen::MatrixXd>& inputs) {
  return predictor_weight(noise, 1).filter(output_error(row, output, inputs));
}

}  // namespace mpmpp
