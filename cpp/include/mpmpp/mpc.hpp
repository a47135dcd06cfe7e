#pragma once
// Linear MPC on the nominal MIMO model, in the form of the paper's MD-MPC (Section 5,
// Tables 2 and 4). At each sample t it measures y(t), chooses the moves
// du(t), ..., du(t+Hc-1) (inputs held afterwards) and applies u(t) = u(t-1) + du(t).
//
// Prediction. The forecast of output i is taken at the Hp samples t+d_i, ..., t+d_i+Hp-1,
// where d_i is the smallest dead time (first non-zero step-response sample) among the
// model channels into output i: a move cannot change output i before t+d_i, so measuring
// the horizon from there (MD-control practice) keeps Hp meaningful when a delay exceeds it
// (Table 4: Hp = 20 with a 23-sample delay on G22, d_2 = 19).
//   yhat_i(t+d_i+k) = f_i(k) + sum_j sum_m S_ij(d_i+k-m) du_j(t+m)
// with S_ij the model step response and f_i the free response: the nominal model run
// forward with u held at u(t-1), plus the forecast of the output disturbance
// v_i = y_i - ymodel_i. Two disturbance models, both offset-free:
//  - Bias (DMC): v_i(t) held constant over the horizon;
//  - NoiseModel (GPC's C/Delta): v_i = H_i / (1 - q^-1) e_i with H_i the model's noise model,
//    so Delta v_i is forecast by H_i's own predictor from the innovations e = H_i^-1 Delta v:
//    vhat(t+k) = v(t) + sum_{s=1..k} Delta vhat(t+s). With H_i = 1 it is the bias model.
//
// Cost (condensed in du and slacks s; P and A fixed, only q, l, u change per sample):
//   sum_i cv_target_weight_i   sum_k (yhat_i(k) - cv_target_i)^2
// + sum_j move_weight_j        sum_m du_j(m)^2                      ("actuator movement")
// + sum_j mv_target_weight_j   sum_m ((u_j(m) - mv_target_j) / range_j)^2
// + sum_j deviation_weight_j   sum_m (u_j(m) - u_j(t-1))^2          ("actuator deviation")
// + cv_minmax_weight, mv_minmax_weight  on the squared slacks of the soft limits.
// Units: engineering units, except that the MV target term is normalised by the MV's
// range (mv_max - mv_min; 1 when unbounded). The paper gives no units; with the tables'
// equal raw weights (CV target 1, MV target 1) the MV target would fight the CV target and
// leave offsets the paper's figures do not show, while the normalised term only settles
// redundant MVs.
// Hard: mv_min <= u <= mv_max and |du| <= mv_max_move over the control horizon.
// Soft (one slack per variable and kind, slack >= 0): cv_min <= yhat <= cv_max;
// mv_soft_min <= u <= mv_soft_max; and |yhat_i(k) - yhat_i(k-1)| <= cv_max_move_i for the
// part of the forecast the moves cause (Table 4's "limits of CV movement": the controller may
// not move a CV faster than this per sample; the free response is not the controller's
// doing and is left out so noise cannot make the limit bind).
#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "mpmpp/model.hpp"
#include "mpmpp/qp.hpp"

namespace mpmpp {

namespace detail {
class IncrementalFilter;
}

enum class DisturbanceModel { Bias, NoiseModel };

// Every vector is per CV (size = outputs) or per MV (size = inputs); an empty vector takes
// the default given. Infinite limits mean "none".
struct MpcTuning {
  int prediction_horizon = 20;       // Hp >= 1, samples counted from each output's smallest delay
  int control_horizon = 2;           // 1 <= Hc <= Hp
  Eigen::VectorXd cv_target;         // required
  Eigen::VectorXd mv_target;         // default: the initial inputs
  Eigen::VectorXd cv_target_weight;  // default 1
  Eigen::VectorXd mv_target_weight;  // default 0
  Eigen::VectorXd move_weight;       // required > 0 (keeps P positive definite)
  Eigen::VectorXd deviation_weight;  // default 0
  Eigen::VectorXd cv_minmax_weight;  // default 1; > 0 where a CV soft limit is finite
  Eigen::VectorXd mv_minmax_weight;  // default 1; > 0 where an MV soft limit is finite
  Eigen::VectorXd mv_min, mv_max;    // hard, default -inf/+inf
  Eigen::VectorXd mv_max_move;       // hard |du|, default +inf
  Eigen::VectorXd cv_min, cv_max;    // soft, default -inf/+inf
  Eigen::VectorXd cv_max_move;       // soft, default +inf
  Eigen::VectorXd mv_soft_min, mv_soft_max;  // soft, default -inf/+inf
  DisturbanceModel disturbance = DisturbanceModel::Bias;
  // How mv_max_move acts: false (the default), as hard QP constraints on every planned move;
  // true, as a DMC with move clipping does it: the QP plans without them and the first move
  // is clipped to +-mv_max_move (then to [mv_min, mv_max]) before it is applied.
  bool clip_moves = false;
};

class Mpc {
 public:
  // u_initial: the inputs applied before the first step (inside the hard bounds). The
  // nominal model's filters start at rest there. Bad sizes/values throw InputError naming
  // the field; every model channel must be strictly proper.
  Mpc(const Model& model, MpcTuning tuning, const Eigen::Ref<const Eigen::VectorXd>& u_initial,
      QpSettings qp_settings = {});
  ~Mpc();
  Mpc(Mpc&&) noexcept;
  Mpc& operator=(Mpc&&) noexcept;

  // One sample: y(t) in absolute units -> u(t). If the QP solve does not end Solved, the
  // solver's best iterate is projected onto the hard limits and failed_solves() counts it.
  const Eigen::VectorXd& step(const Eigen::Ref<const Eigen::VectorXd>& y);

  void set_cv_target(int output, double value);
  void set_mv_target(int input, double value);

  const MpcTuning& tuning() const;
  const Eigen::VectorXd& u() const;                 // last applied inputs
  const Eigen::VectorXi& prediction_start() const;  // d_i per output
  // The condensed QP: P, A fixed; q, l, u of the last step. Variables: du (index m*nu + j)
  // then the slacks.
  const Eigen::MatrixXd& qp_P() const;
  const Eigen::MatrixXd& qp_A() const;
  const Eigen::VectorXd& qp_q() const;
  const Eigen::VectorXd& qp_l() const;
  const Eigen::VectorXd& qp_u() const;
  const QpResult& last_result() const;
  // Dynamic matrix Theta (rows: output i, k = 0..Hp-1 stacked; cols: du) and the last
  // free response f (same rows, disturbance estimate included).
  const Eigen::MatrixXd& dynamic_matrix() const;
  const Eigen::VectorXd& free_response() const;
  const Eigen::VectorXd& disturbance_estimate() const;
  int num_variables() const;
  int failed_solves() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mpmpp
