#pragma once
// Control-valve models: the map from controller output (OP) to valve position, in OP units.
// Stick-slip models follow Choudhury, Thornhill & Shah (2005), "Modelling valve stiction",
// Control Eng. Practice 13, and He, Wang, Pottmann & Qin (2007), "A curve fitting method for
// detecting valve stiction in oscillating control loops", IECR 46. Both are sample-by-sample
// state machines, so a closed-loop simulator can call step() inside its loop.
#include <Eigen/Dense>

namespace mpmpp {

enum class ValveKind {
  Linear,      // position = OP
  StickSlip,   // Choudhury: a = S (deadband + stickband), b = J (slip jump), 0 <= J <= S
  He,          // He et al.: a = fs (static friction band), b = fd (dynamic), 0 <= fd <= fs
  Backlash,    // Choudhury with J = 0: a = width of the band the OP must cross on reversal
  Deadband,    // static dead zone: a = half-width, b = centre (position = centre inside)
  Saturation,  // a = lower, b = upper limit of the valve travel
};

class Valve {
 public:
  Valve(ValveKind kind, double a, double b);
  // Position for the next OP sample; the first call fixes the starting position (= OP).
  double step(double op);
  void reset();
  // Positions for a whole OP sequence from a reset valve.
  Eigen::VectorXd apply(const Eigen::Ref<const Eigen::VectorXd>& op);
  ValveKind kind() const { return kind_; }

 private:
  double step_stick_slip(double op, double S, double J);
  double step_he(double op);

  ValveKind kind_;
  double a_, b_;
  bool started_ = false;
  double prev_op_ = 0.0, position_ = 0.0;
  // stick-slip state: stuck at OP x_stuck_; last direction of travel (+1, -1, 0 = none yet)
  bool stuck_ = true;
  double x_stuck_ = 0.0;
  int direction_ = 0;
  // He model: friction force accumulated while stuck
  double residual_ = 0.0;
};

}  // namespace mpmpp
