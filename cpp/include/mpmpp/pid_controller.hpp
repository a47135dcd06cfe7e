#pragma once
// Decentralised (multi-loop) PID control: each loop pairs one CV with one MV; inputs without
// a loop stay at their initial value. Per loop, in velocity (incremental) form:
//   e(t)  = r(t) - y(t)
//   D(t)  = a D(t-1) - b (y(t) - y(t-1)),   a = Tf / (Tf + Ts), b = Td / (Tf + Ts), Tf = Td / N
//           (derivative on the measurement, first-order filtered, backward difference, so a
//           setpoint step gives no derivative kick)
//   du(t) = K [ e(t) - e(t-1) + (Ts / Ti) e(t) + D(t) - D(t-1) ]
//   u(t)  = clip(u(t-1) + du(t), min, max)
// The velocity form clips the applied output itself, so the integral cannot wind up against
// the saturation. K carries the sign of the action: K > 0 for a process gain > 0.
#include <Eigen/Dense>
#include <limits>
#include <vector>

namespace mpmpp {

struct PidLoop {
  int output = 0;
  int input = 0;
  double gain = 0.0;                                                 // K
  double integral_time_s = std::numeric_limits<double>::infinity();  // Ti; inf = no integral
  double derivative_time_s = 0.0;                                    // Td; 0 = PI
  double derivative_filter = 10.0;                                   // N
  double min = -std::numeric_limits<double>::infinity();             // output saturation
  double max = std::numeric_limits<double>::infinity();
};

class PidController {
 public:
  // Loops must pair distinct outputs with distinct inputs; u_initial (inside each loop's
  // saturation) is the output before the first step, setpoint the initial r. InputError
  // naming the loop otherwise.
  PidController(std::vector<PidLoop> loops, int num_outputs, double sample_time_s,
                const Eigen::Ref<const Eigen::VectorXd>& u_initial,
                const Eigen::Ref<const Eigen::VectorXd>& setpoint);

  // One sample: y(t) -> u(t).
  const Eigen::VectorXd& step(const Eigen::Ref<const Eigen::VectorXd>& y);
  void set_setpoint(int output, double value);
  const Eigen::VectorXd& setpoint() const { return setpoint_; }

 private:
  std::vector<PidLoop> loops_;
  double ts_;
  Eigen::VectorXd u_, setpoint_;
  Eigen::VectorXd previous_error_, previous_y_, derivative_;
  bool started_ = false;
};

// u(t) for a whole record of outputs y (samples x outputs) with setpoints r (same shape): the
// controller open to any y sequence (for tests against a reference implementation).
Eigen::MatrixXd pid_outputs(const std::vector<PidLoop>& loops, double sample_time_s,
                            const Eigen::Ref<const Eigen::VectorXd>& u_initial,
                            const Eigen::Ref<const Eigen::MatrixXd>& y,
                            const Eigen::Ref<const Eigen::MatrixXd>& setpoint);

}  // namespace mpmpp
