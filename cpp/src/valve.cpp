#include "mpmpp/valve.hpp"

#include <cmath>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {
int sign_of(double x) { return (x > 0.0) - (x < 0.0); }
}  // namespace

Valve::Valve(ValveKind kind, double a, double b) : kind_(kind), a_(a), b_(b) {
  if (!std::isfinite(a) || !std::isfinite(b)) throw InputError("valve parameters must be finite");
  switch (kind) {
    case ValveKind::StickSlip:
      if (a < 0.0 || b < 0.0 || b > a)
        throw InputError("stick-slip valve needs 0 <= J <= S (got S=" + std::to_string(a) +
                         ", J=" + std::to_string(b) + ")");
      break;
    case ValveKind::He:
      if (a < 0.0 || b < 0.0 || b > a)
        throw InputError("He valve needs 0 <= fd <= fs (got fs=" + std::to_string(a) +
                         ", fd=" + std::to_string(b) + ")");
      break;
    case ValveKind::Backlash:
    case ValveKind::Deadband:
      if (a < 0.0) throw InputError("valve band width must be >= 0");
      break;
    case ValveKind::Saturation:
      if (!(a < b)) throw InputError("valve saturation needs lower < upper limit");
      break;
    case ValveKind::Linear:
      break;
  }
}

void Valve::reset() {
  started_ = false;
  stuck_ = true;
  direction_ = 0;
  residual_ = 0.0;
}

// Choudhury's flowchart: the valve sticks when the OP halts or reverses. To move again the OP
// must travel J beyond the sticking point when it keeps its direction (stickband only) and S
// when it reverses (deadband + stickband); once moving, position = OP - d (S - J) / 2, so the
// slip is a jump of J.
double Valve::step_stick_slip(double op, double S, double J) {
  const int velocity = sign_of(op - prev_op_);
  if (!stuck_ && velocity != direction_) {
    stuck_ = true;
    x_stuck_ = prev_op_;
  }
  if (stuck_) {
    const double travel = op - x_stuck_;
    const int d = sign_of(travel);
    const double band = (d == direction_) ? J : S;
    if (d != 0 && std::abs(travel) > band) {
      stuck_ = false;
      direction_ = d;
      position_ = op - d * (S - J) / 2.0;
    }
  } else {
    position_ = op - direction_ * (S - J) / 2.0;
  }
  return position_;
}

// He et al.: the net force (OP change accumulated while stuck) must exceed fs; once it does the
// valve follows the OP lagging by fd, and the force left over is fd.
double Valve::step_he(double op) {
  const double force = residual_ + (op - prev_op_);
  if (std::abs(force) > a_) {
    const int d = sign_of(force);
    position_ = op - d * b_;
    residual_ = d * b_;
  } else {
    residual_ = force;
  }
  return position_;
}

double Valve::step(double op) {
  if (!std::isfinite(op)) throw InputError("valve input (OP) must be finite");
  if (!started_) {
    started_ = true;
    prev_op_ = op;
    x_stuck_ = op;
    position_ = op;  // the memory models start at rest at the first OP
  }
  switch (kind_) {
    case ValveKind::Linear:
      position_ = op;
      break;
    case ValveKind::StickSlip:
      step_stick_slip(op, a_, b_);
      break;
    case ValveKind::Backlash:
      step_stick_slip(op, a_, 0.0);
      break;
    case ValveKind::He:
      step_he(op);
      break;
    case ValveKind::Deadband: {
      const double off = op - b_;
      position_ = std::abs(off) <= a_ ? b_ : op - sign_of(off) * a_;
      break;
    }
    case ValveKind::Saturation:
      position_ = std::min(std::max(op, a_), b_);
      break;
  }
  prev_op_ = op;
  return position_;
}

Eigen::VectorXd Valve::apply(const Eigen::Ref<const Eigen::VectorXd>& op) {
  reset();
  Eigen::VectorXd out(op.size());
  for (Eigen::Index k = 0; k < op.size(); ++k) out[k] = step(op[k]);
  return out;
}

}  // namespace mpmpp
