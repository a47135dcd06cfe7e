#pragma once
// Actuator (control valve) between a command (MV, controller OP) and the plant: the position
// the valve actually takes, in the command's units. One model serves the closed-loop simulator
// and the stiction analysis. Nonlinearities, applied in this order:
// stiction, two-parameter, S = deadband + stickband and J = slip jump (0 <= J <= S), by one of
//   Choudhury, Thornhill and Shah, "Modelling valve stiction", Control Eng. Practice 13 (2005):
//     the valve sticks when the command stops or reverses; it breaks free when the command has
//     moved more than S from where it stuck (more than J if it keeps the direction it had
//     before stopping) and then jumps to command - sign(velocity) (S - J) / 2;
//   He, Wang, Pottmann and Qin, "A curve fitting method for detecting valve stiction in
//     oscillating control loops", IECR 46 (2007): the command change accumulated while stuck
//     must exceed the static friction fs; the moving valve lags the command by the dynamic
//     friction fd and the accumulated change restarts from fd. He et al. map their parameters
//     to Choudhury's as S = fs + fd, J = fs - fd, so both laws take (S, J);
// deadband: the range through which the command can vary without an observable change of
//   position (ANSI/ISA-51.1), as a valve positioner applies it: the position stays put until
//   the command differs from it by more than `deadband`, then goes to the command;
// backlash: the play operator of width `backlash` (Tao and Kokotovic, "Adaptive control of
//   systems with actuator and sensor nonlinearities", 1996): the position follows the command
//   only when pushed, lagging it by half the width; starting centred it has no slip jump,
//   unlike Choudhury's model with J = 0 started from rest;
// saturation: the position is clipped to [min, max].
// Every stage starts at rest at a given position u0 (the command before the record).
#include <Eigen/Dense>
#include <limits>
#include <string>

namespace mpmpp {

enum class StictionLaw { Choudhury, He };

struct ActuatorNonlinearity {
  StictionLaw stiction_law = StictionLaw::Choudhury;
  double stiction_s = 0.0;  // S; 0 = no stiction
  double stiction_j = 0.0;  // J, 0 <= J <= S
  double deadband = 0.0;
  double backlash = 0.0;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
};

// InputError naming `at` when a parameter is out of range.
void check_actuator(const ActuatorNonlinearity& a, const std::string& at);

class Actuator {
 public:
  Actuator() = default;
  // Checked parameters, at rest at u0.
  Actuator(const ActuatorNonlinearity& nl, double u0);
  void set(const ActuatorNonlinearity& nl) { nl_ = nl; }
  // Position and command history start at u0, at rest.
  void start(double u0);
  // Command -> position, one sample.
  double move(double command);

 private:
  double choudhury(double command);
  double he(double command);

  ActuatorNonlinearity nl_;
  double previous_command_ = 0.0;
  double direction_ = 0.0;  // sign of the last non-zero command velocity
  bool stuck_ = true;
  double stuck_command_ = 0.0;    // x_ss: the command when the valve last stuck
  double stuck_direction_ = 0.0;  // direction of travel before it stuck
  double force_ = 0.0;            // He: command change accumulated since the last slip
  double stiction_out_ = 0.0;     // after the stiction
  double deadband_out_ = 0.0;     // after the deadband
  double play_ = 0.0;             // after the backlash
};

// Positions for a whole command sequence from rest at u0.
Eigen::VectorXd actuator_positions(const Eigen::Ref<const Eigen::VectorXd>& commands,
                                   const ActuatorNonlinearity& nl, double u0);

}  // namespace mpmpp
