#pragma once
// Covariance of ARX-OE's FIR parameters with the ARX step's A(q) uncertainty carried
// through (delta method on the stacked estimating equations of the two steps).
//
// The OE step's own covariance sigma^2 (Z'Z)^-1 treats the filter A(q) of eq. (9) as
// exact. In closed loop it is not harmless: u is correlated with past noise, so an error
// in A moves the FIR estimate. With the ARX step  sum_t phi_t e_t = 0  (theta1 = [a, b])
// and the FIR OE step  sum_{t>=na} z_t eps_t = 0  (z_t: the A-filtered inputs' lags,
// eps = A y - Z theta2), linearising both around the truth gives
//   theta2 - theta2_0 = (Z'Z)^-1 sum_t w_t,
//   w_t = z_t eps_t + M21 (Phi'Phi)^-1 phi_t e_t,
//   M21[:, a_k] = d(sum_t z_t eps_t)/d a_k = sum_t (zraw_{t-k} eps_t + z_t vhat_{t-k}),
// where zraw_t are the unfiltered inputs' lags and vhat = y - sum_j G_j u_j the
// unfiltered output error (d eps_t / d a_k = vhat_{t-k}); M21 is zero on the b columns.
// The covariance is the sandwich (Z'Z)^-1 (sum_t w_t w_t') (Z'Z)^-1, times
// N_eq / (N_eq - p) as the OE noise variance's degrees of freedom. (Phi'Phi)^-1 comes from
// the ARX step's own factorisation, so a ridge it added (ArxOptions::delta) is included.
// Measured on the paper MIMO example (studies/arx_step_uncertainty.py): output 3's
// G32 coefficients spread with sd 0.0047 over seeds; this covariance gives 0.0052, the
// OE step's own 0.0026.
#include <Eigen/Dense>
#include <vector>

#include "mpmpp/arx.hpp"
#include "mpmpp/output_error.hpp"

namespace mpmpp {

class TwoStepCovariance {
 public:
  // InputError unless every channel is FIR (nf = 0): the only structure it is derived for.
  static void require_fir(const std::vector<OeChannel>& channels);

  // y: the detrended window, u: its detrended inputs (N x m), yf/uf: the same filtered
  // by the estimated A(q); arx_estimator: the ARX step that just estimated arx from y, u
  // (both still alive); fir: the OE channels (require_fir); oe: the OE estimate (fitted
  // over t >= na). Writes the covariance of oe.theta (p x p); reuses its workspace
  // between windows.
  void compute(const Eigen::Ref<const Eigen::VectorXd>& y,
               const Eigen::Ref<const Eigen::MatrixXd>& u,
               const Eigen::Ref<const Eigen::VectorXd>& yf,
               const Eigen::Ref<const Eigen::MatrixXd>& uf, const ArxEstimator& arx_estimator,
               const ArxResult& arx, const std::vector<OeChannel>& fir, const OeResult& oe,
               Eigen::MatrixXd& covariance);

 private:
  Eigen::MatrixXd phi_, z_, zraw_, vhat_lags_, eps_leads_, m21_, x_, w_, zz_inv_;
  Eigen::VectorXd e_, eps_, vhat_;
  Eigen::LLT<Eigen::MatrixXd> llt_{Eigen::MatrixXd(0, 0)};
};

}  // namespace mpmpp
