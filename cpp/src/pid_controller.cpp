#include "mpmpp/pid_controller.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

PidController::PidController(std::vector<PidLoop> loops, int num_outputs, double sample_time_s,
                             const Eigen::Ref<const Eigen::VectorXd>& u_initial,
                             const Eigen::Ref<const Eigen::VectorXd>& setpoint)
    : loops_(std::move(loops)), ts_(sample_time_s), u_(u_initial), setpoint_(setpoint) {
  if (!(ts_ > 0.0) || !std::isfinite(ts_)) throw InputError("PID sample time must be > 0");
  if (setpoint_.size() != num_outputs)
    throw InputError("PID setpoints must have one value per output");
  if (!u_.allFinite() || !setpoint_.allFinite())
    throw InputError("PID initial inputs and setpoints must be finite");
  std::vector<bool> output_used(num_outputs, false), input_used(u_.size(), false);
  for (size_t k = 0; k < loops_.size(); ++k) {
    const PidLoop& l = loops_[k];
    const std::string at = "PID loop " + std::to_string(k);
    if (l.output < 0 || l.output >= num_outputs)
      throw InputError(at + ": output index out of range");
    if (l.input < 0 || l.input >= u_.size()) throw InputError(at + ": input index out of range");
    if (output_used[l.output] || input_used[l.input])
      throw InputError(at + ": each output and each input may be in one loop only");
    output_used[l.output] = input_used[l.input] = true;
    if (!std::isfinite(l.gain) || l.gain == 0.0)
      throw InputError(at + ": gain must be finite and non-zero");
    if (!(l.integral_time_s > 0.0))
      throw InputError(at + ": integral time must be > 0 (inf: none)");
    if (!(l.derivative_time_s >= 0.0) || !std::isfinite(l.derivative_time_s))
      throw InputError(at + ": derivative time must be a finite value >= 0");
    if (!(l.derivative_filter > 0.0) || !std::isfinite(l.derivative_filter))
      throw InputError(at + ": derivative filter N must be > 0");
    if (!(l.min <= l.max)) throw InputError(at + ": min must be <= max");
    if (u_[l.input] < l.min || u_[l.input] > l.max)
      throw InputError(at + ": the initial input must lie within [min, max]");
  }
  previous_error_ = Eigen::VectorXd::Zero(num_outputs);
  previous_y_ = Eigen::VectorXd::Zero(num_outputs);
  derivative_ = Eigen::VectorXd::Zero(num_outputs);
}

const Eigen::VectorXd& PidController::step(const Eigen::Ref<const Eigen::VectorXd>& y) {
  if (y.size() != setpoint_.size()) throw InputError("PID step: y must have one value per output");
  if (!started_) {  // bumpless start: no error or measurement change before the first sample
    previous_y_ = y;
    previous_error_ = setpoint_ - y;
    started_ = true;
  }
  for (const PidLoop& l : loops_) {
    const int i = l.output;
    const double e = setpoint_[i] - y[i];
    double d_change = 0.0;
    if (l.derivative_time_s > 0.0) {
      const double tf = l.derivative_time_s / l.derivative_filter;
      const double d =
          (tf * derivative_[i] - l.derivative_time_s * (y[i] - previous_y_[i])) / (tf + ts_);
      d_change = d - derivative_[i];
      derivative_[i] = d;
    }
    const double du = l.gain * (e - previous_error_[i] + ts_ / l.integral_time_s * e + d_change);
    u_[l.input] = std::clamp(u_[l.input] + du, l.min, l.max);
    previous_error_[i] = e;
  }
  previous_y_ = y;
  return u_;
}

void PidController::set_setpoint(int output, double value) {
  if (output < 0 || output >= setpoint_.size())
    throw InputError("PID setpoint: output index out of range");
  setpoint_[output] = value;
}

Eigen::MatrixXd pid_outputs(const std::vector<PidLoop>& loops, double sample_time_s,
                            const Eigen::Ref<const Eigen::VectorXd>& u_initial,
                            const Eigen::Ref<const Eigen::MatrixXd>& y,
                            const Eigen::Ref<const Eigen::MatrixXd>& setpoint) {
  if (setpoint.rows() != y.rows() || setpoint.cols() != y.cols())
    throw InputError("pid_outputs: y and setpoint must have the same shape");
  if (y.rows() == 0) return Eigen::MatrixXd(0, u_initial.size());
  PidController pid(loops, static_cast<int>(y.cols()), sample_time_s, u_initial,
                    setpoint.row(0).transpose());
  Eigen::MatrixXd u(y.rows(), u_initial.size());
  for (Eigen::Index t = 0; t < y.rows(); ++t) {
    for (Eigen::Index i = 0; i < y.cols(); ++i)
      pid.set_setpoint(static_cast<int>(i), setpoint(t, i));
    u.row(t) = pid.step(y.row(t).transpose()).transpose();
  }
  return u;
}

}  // namespace mpmpp
