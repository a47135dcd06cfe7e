#pragma once
// Closed-loop simulation: true plant = MIMO Box-Jenkins
//   y_i(t) = y0_i + sum_j G0_ij (ua_j - u0_j)(t) + sum_k X_ik (x_k - x0_k)(t) + H0_i (sigma_i
//   e_i)(t) + drift_i(t)
// (e white Gaussian, unit variance, from a seeded generator), controlled by the MPC on the
// nominal model or, when pid_loops is given, by decentralised PID loops (pid_controller.hpp). ua is
// the actuators' actual position: the commanded MV after the optional actuator nonlinearity. x_k
// are measured extra variables (x_k = x0_k + Hx_k (sigma_k e)), entering outputs through channels
// X_ik the model lacks. Every filter keeps incremental state, so a run costs O(samples * channels *
// order) plus one QP per sample.
//
// Events change the truth or the controller's targets at a given sample (applied before
// y(t) is formed). A replaced channel or noise model acts as if it had always been in place
// on the recorded input (or innovation) history, in deviation units around the operating
// point: it is replayed over that history once, so the change shows without an artificial
// transient from a filter-state mismatch. A process event with `fresh` switches the other
// way, as a simulator that swaps a channel's filter does: the new channel starts from rest on
// the inputs from the event on, and the old one's response to the earlier inputs fades out
// (its filter fed zeros), so y_ij = G_old (u 1[s < k - 1]) + G_new (u 1[s >= k - 1]) with the
// one-sample advance below.
#include <Eigen/Dense>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "mpmpp/actuator.hpp"
#include "mpmpp/model.hpp"
#include "mpmpp/mpc.hpp"
#include "mpmpp/pid_controller.hpp"
#include "mpmpp/qp.hpp"
#include "mpmpp/transfer_function.hpp"

namespace mpmpp {

// A measured variable outside the model: x = operating_point + noise (sigma e).
struct ExtraVariable {
  std::string name;
  double operating_point = 0.0;
  double sigma = 0.0;
  TransferFunction noise;  // default H = 1
};

struct Plant {
  std::vector<std::vector<std::optional<TransferFunction>>> process;  // [output][input]
  std::vector<TransferFunction> noise;                                // [output]
  Eigen::VectorXd sigma;                                              // [output]
  std::vector<ExtraVariable> extra;                                   // measured, not in the model
  std::vector<std::vector<std::optional<TransferFunction>>>
      extra_process;                            // [output][extra]; empty = none
  std::vector<ActuatorNonlinearity> actuators;  // [input]; empty = linear
  // Measurement outliers (a historian's spikes; the controller sees them too): at each sample
  // and output, with probability outlier_probability, y is off by +-outlier_size[output].
  // Drawn from their own seeded stream, so they leave the noise sequence unchanged.
  double outlier_probability = 0.0;
  Eigen::VectorXd outlier_size;  // [output]
};

enum class EventKind {
  Process,       // replace truth channel (output, input) by `model`; nullopt removes it
  ExtraProcess,  // replace the channel (output, extra index in `input`) from an extra variable
  Noise,         // replace output's H0 by `model`
  Sigma,         // output's noise standard deviation becomes `value`
  Drift,         // output: add the step `value` and set the slope to `rate` (units/sample)
  Actuator,      // input's actuator nonlinearity becomes `actuator`
  CvTarget,      // output's CV target (setpoint) becomes `value`
  MvTarget,      // input's MV target becomes `value` (MPC only)
};

struct Event {
  int sample = 0;
  EventKind kind = EventKind::Process;
  int output = -1;
  int input = -1;
  std::optional<TransferFunction> model;
  double value = 0.0;
  double rate = 0.0;
  ActuatorNonlinearity actuator;
  bool fresh = false;  // Process: the new channel from rest, the old one fading (see above)
};

struct ClosedLoopConfig {
  Model model;       // nominal: what the MPC uses
  MpcTuning tuning;  // the MPC's; with pid_loops only cv_target / mv_target (start point)
  std::vector<PidLoop> pid_loops;  // non-empty: multi-loop PID control instead of the MPC
  Plant plant;                     // truth
  Eigen::VectorXd u_operating;     // u0 (start inputs); default: tuning.mv_target
  Eigen::VectorXd y_operating;     // y0; default: tuning.cv_target
  int num_samples = 0;
  std::uint64_t seed = 0;
  std::vector<Event> events;  // any order; applied in sample order, ties in list order
  bool record_qps = false;
  QpSettings qp_settings;
  // Given sequences for studies whose disturbances the noise models cannot produce (a
  // sinusoid, a recorded disturbance): added to y [samples x outputs] and to the actuator
  // position after its nonlinearity [samples x inputs]. Empty = none.
  Eigen::MatrixXd output_disturbance;
  Eigen::MatrixXd position_noise;
};

struct SimulationResult {
  Eigen::MatrixXd u;         // [samples x inputs] MV commands (what a historian records)
  Eigen::MatrixXd u_actual;  // [samples x inputs] actuator positions after the nonlinearity
  Eigen::MatrixXd y;         // [samples x outputs]
  Eigen::MatrixXd setpoint;  // [samples x outputs] CV targets in force
  Eigen::MatrixXd extra;     // [samples x extra variables]
  int failed_solves = 0;
  // With record_qps: every QP (P, A fixed; one row of q, l, u per sample).
  Eigen::MatrixXd qp_P, qp_A, qp_q, qp_l, qp_u;
};

SimulationResult simulate_closed_loop(const ClosedLoopConfig& config);

}  // namespace mpmpp
