#include "mpmpp/actuator.hpp"

#include <algorithm>
#include <cmath>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {
double sign(double x) { return (x > 0.0) - (x < 0.0); }
}  // namespace

void check_actuator(const ActuatorNonlinearity& a, const std::string& at) {
  auto nonnegative = [&](double v, const char* what) {
    if (!(v >= 0.0) || !std::isfinite(v))
      throw InputError(at + " " + what + " must be a finite value >= 0");
  };
  nonnegative(a.stiction_s, "stiction S");
  nonnegative(a.stiction_j, "stiction J");
  nonnegative(a.deadband, "deadband");
  nonnegative(a.backlash, "backlash");
  if (a.stiction_j > a.stiction_s) throw InputError(at + " stiction J must be <= S");
  if (!(a.min <= a.max)) throw InputError(at + " saturation min must be <= max");
}

Actuator::Actuator(const ActuatorNonlinearity& nl, double u0) : nl_(nl) {
  check_actuator(nl, "actuator");
  if (!std::isfinite(u0)) throw InputError("actuator start position u0 must be finite");
  start(u0);
}

void Actuator::start(double u0) {
  previous_command_ = stuck_command_ = stiction_out_ = deadband_out_ = play_ = u0;
  direction_ = stuck_direction_ = force_ = 0.0;
  stuck_ = true;
}

double Actuator::choudhury(double x) {
  const double velocity = sign(x - previous_command_);
  if (!stuck_ && velocity != direction_) {
    // The command stopped or reversed: the valve sticks at x_ss, the last command it followed.
    stuck_ = true;
    stuck_command_ = previous_command_;
    stuck_direction_ = direction_;
  }
  previous_command_ = x;
  if (stuck_) {
    // Breaking free takes more than J of travel when the command keeps its earlier direction
    // (the deadband is already taken up), more than S when it reverses or starts from rest.
    const double travel = x - stuck_command_;
    const double limit = sign(travel) == stuck_direction_ ? nl_.stiction_j : nl_.stiction_s;
    if (velocity != sign(travel) || std::abs(travel) <= limit) return stiction_out_;
    stuck_ = false;
  }
  direction_ = velocity;
  stiction_out_ = x - velocity * 0.5 * (nl_.stiction_s - nl_.stiction_j);
  return stiction_out_;
}

double Actuator::he(double x) {
  const double fs = 0.5 * (nl_.stiction_s + nl_.stiction_j);
  const double fd = 0.5 * (nl_.stiction_s - nl_.stiction_j);
  force_ += x - previous_command_;
  previous_command_ = x;
  if (std::abs(force_) > fs) {
    const double d = sign(force_);
    stiction_out_ = x - d * fd;
    force_ = d * fd;
  }
  return stiction_out_;
}

double Actuator::move(double command) {
  // Both laws are the identity when S = 0.
  const double x = nl_.stiction_law == StictionLaw::He ? he(command) : choudhury(command);
  if (std::abs(x - deadband_out_) > nl_.deadband) deadband_out_ = x;
  const double half = 0.5 * nl_.backlash;
  if (deadband_out_ > play_ + half)
    play_ = deadband_out_ - half;
  else if (deadband_out_ < play_ - half)
    play_ = deadband_out_ + half;
  return std::clamp(play_, nl_.min, nl_.max);
}

Eigen::VectorXd actuator_positions(const Eigen::Ref<const Eigen::VectorXd>& commands,
                                   const ActuatorNonlinearity& nl, double u0) {
  if (!commands.allFinite()) throw InputError("actuator commands must be finite");
  Actuator a(nl, u0);
  Eigen::VectorXd out(commands.size());
  for (Eigen::Index t = 0; t < commands.size(); ++t) out[t] = a.move(commands[t]);
  return out;
}

}  // namespace mpmpp
