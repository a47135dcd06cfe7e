#pragma once
// Actuator between an MV command and the plant: the position the valve or drive actually
// takes. Nonlinearities, applied in this order:
// stiction: Choudhury, Thornhill and Shah's two-parameter data-driven model ("Modelling valve
//   stiction", Control Eng. Practice 13, 2005): S = deadband + stickband, J = slip jump, both
//   in the command's units. The valve sticks when the command stops or reverses; it breaks
//   free when the command has moved more than S from where it stuck (more than J if it keeps
//   the direction it had before stopping) and then jumps to command - sign(velocity) (S - J) / 2;
// deadband: the position stays put until the command differs from it by more than
//   `deadband`, then jumps to the command (the stick-slip of a stiction model with J = S);
// backlash: play of width `backlash`; the position follows the command only when pushed,
//   lagging it by half the width;
// saturation: the position is clipped to [min, max].
#include <limits>
#include <string>

#include <Eigen/Dense>

namespace mpmpp {

struct ActuatorNonlinearity {
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
  void set(const ActuatorNonlinearity& nl) { nl_ = nl; }
  // Position and command history start at u0, at rest.
  void start(double u0);
  // Command -> position.
  double move(double command);

 private:
  double stick_slip(double command);

  ActuatorNonlinearity nl_;
  double previous_command_ = 0.0;
  double direction_ = 0.0;        // sign of the last non-zero command velocity
  bool stuck_ = true;
  double stuck_command_ = 0.0;    // x_ss: the command when the valve last stuck
  double stuck_direction_ = 0.0;  // direction of travel before it stuck
  double stiction_out_ = 0.0;     // after the stiction
  double deadband_out_ = 0.0;     // after the deadband
  double play_ = 0.0;             // after the backlash
};

// Positions for a whole command sequence from rest at u0 (for tests and diagnosis).
Eigen::VectorXd actuator_positions(const Eigen::Ref<const Eigen::VectorXd>& commands,
                                   const ActuatorNonlinearity& nl, double u0);

}  // namespace mpmpp
