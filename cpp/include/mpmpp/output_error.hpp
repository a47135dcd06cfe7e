#pragma once
// Output-error step of ARX-OE (Section 3.2, eqs. (9)-(10), MISO form of Section 3.3):
// per output, all its channels jointly,
//   y(t) = sum_j G_j(q) u_j(t) + eps(t),
//   G_j(q) = q^-d_j (b_j0 + b_j1 q^-1 + ... + b_j,nb_j-1 q^-(nb_j-1))
//                 / (1 + f_j1 q^-1 + ... + f_j,nf_j q^-nf_j),
// minimising sum_{t=skip}^{N-1} eps(t)^2 with zero initial state (G_j u_j simulated from
// sample 0; lfilter semantics). In ARX-OE, y and u_j are the A(q)-filtered signals and
// skip = na (the filter's start-up samples). Structures:
//   first-order plus dead time  b q^-d / (1 + f q^-1):  OeChannel::foptd(d)  (nb = 1, nf = 1)
//   general OE (nb, nf):                                OeChannel{nb, nf, d}
//   FIR of length m (linear least squares):             OeChannel::fir(m, d)  (nf = 0)
// Levenberg-Marquardt with the analytic sensitivities
//   d yhat/d b_jk = q^-k [q^-d_j / F_j] u_j,   d yhat/d f_jk = -q^-k [1 / F_j] yhat_j,
// every F_j kept stable by reflecting roots outside the circle (radius capped at
// max_pole_radius); the damped matrix is Newton's Hessian (second-order sensitivities
// q^-(k+i) q^-d_j/F_j^2 u_j, q^-(i+l) yhat_j/F_j^2) where positive definite, else J'J.
// Start: a Prony/Kalman fit to an impulse response (the caller's, e.g. B_j/A of the ARX
// step, or a joint FIR least-squares fit on the data); for first-order denominators the
// best of that pole and a small pole grid (b_j by least squares).
#include <Eigen/Dense>
#include <vector>

#include "mpmpp/detail/lagged_regression.hpp"

namespace mpmpp {

struct OeChannel {
  int nb = 1;
  int nf = 1;
  int delay = 0;
  static OeChannel foptd(int delay) { return {1, 1, delay}; }
  static OeChannel fir(int length, int delay) { return {length, 0, delay}; }
};

struct OeOptions {
  int max_iterations = 200;
  // Converged when an accepted step has |dtheta|_inf <= step_tolerance (|theta|_inf +
  // step_tolerance) or every gradient component's cosine |J_k' eps| / (|J_k| |eps|) <=
  // gradient_tolerance.
  double step_tolerance = 1e-8;
  double gradient_tolerance = 1e-12;
  double max_pole_radius = 0.9999;
  // FIR length per channel for the start when no impulse response is given; 0 = automatic
  // (max(30, nb + nf + 10), shrunk so the fit keeps >= 4 equations per coefficient).
  int init_fir_length = 0;
  double rank_tolerance = 1e-10;  // as ArxOptions::rank_tolerance, for J'J at the optimum
};

struct OeResult {
  std::vector<Eigen::VectorXd> b;  // b[j] = [b_j0 .. b_j,nb_j-1]
  std::vector<Eigen::VectorXd> f;  // f[j] = [1, f_j1 .. f_j,nf_j]
  Eigen::VectorXd theta;           // per channel [b_j block, f_j1..f_jnf], channels in order
  Eigen::MatrixXd covariance;      // sigma^2 (J'J)^-1 at the optimum
  double noise_variance = 0.0;     // sum(eps^2) / (N_eq - p)
  double cost = 0.0;               // sum(eps^2) / 2 (criterion (10) times N_eq)
  Eigen::Index equations = 0;      // N_eq = N - skip
  int iterations = 0;
  bool converged = false;
};

class OutputErrorEstimator {
 public:
  explicit OutputErrorEstimator(std::vector<OeChannel> channels, OeOptions options = {});

  // y: N samples, u: N x m (column j feeds channel j); views, not copied. The optional
  // initial_impulse[j] is channel j's impulse response from the first sample after its
  // delay. stretch_starts: rows where a new complete stretch of the record begins (after
  // a gap); every stretch's simulation starts at rest and its first `skip` rows are not
  // in the criterion (one stretch: the record is copied once, gaps of zeros between).
  // InputError on bad shapes; NumericalError when the data are not informative.
  void estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                const Eigen::Ref<const Eigen::MatrixXd>& u, Eigen::Index skip, OeResult& out,
                const std::vector<Eigen::VectorXd>* initial_impulse = nullptr,
                const std::vector<Eigen::Index>& stretch_starts = {});
  OeResult estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                    const Eigen::Ref<const Eigen::MatrixXd>& u, Eigen::Index skip = 0,
                    const std::vector<Eigen::Index>& stretch_starts = {});

  const std::vector<OeChannel>& channels() const { return channels_; }
  Eigen::Index num_parameters() const { return p_; }
  // Impulse-response length the start fit of channel j uses (see OeOptions), and the
  // FIR start-fit length for a window of n_eq equations (shrunk to the >= 4 rule, may be 0).
  int start_impulse_length(std::size_t j) const;
  int init_fir_length(std::size_t j, Eigen::Index n_eq) const;

 private:
  bool linear() const { return nonlinear_channels_ == 0; }
  // The private steps below work on the laid-out record (y, u of N rows: the stretches_
  // with zero rows between) and sum the criterion over equations_.
  void fir_start(const Eigen::Ref<const Eigen::MatrixXd>& u, const double* y, OeResult& out);
  void prony_start(std::size_t j, const Eigen::Ref<const Eigen::VectorXd>& g, Eigen::VectorXd& b,
                   Eigen::VectorXd& f) const;
  void pole_grid_start(std::size_t j, const Eigen::Ref<const Eigen::MatrixXd>& u, const double* y,
                       Eigen::Index N, OeResult& out);
  void stabilise(Eigen::VectorXd& f) const;
  double criterion_sum_of_squares(const Eigen::VectorXd& x) const;
  // w_j for the given polynomials and e = y - sum_j B_j w_j; returns sum(e^2)/2 over the
  // equations.
  double simulate(const Eigen::Ref<const Eigen::MatrixXd>& u, const double* y, Eigen::Index N,
                  const OeResult& par);
  void jacobian_columns(Eigen::Index N, const OeResult& par);
  // H_ = G_ (J'J at the parameters jacobian_columns() last saw) minus the second-order
  // term, from the s_j and v_j jacobian_columns() left.
  void newton_hessian(Eigen::Index N, const OeResult& par);
  void unpack(const Eigen::VectorXd& theta, OeResult& par) const;
  void pack(const OeResult& par, Eigen::VectorXd& theta) const;
  void throw_if_not_informative(const detail::NormalEquationsSolver::Outcome& o,
                                const char* where) const;

  std::vector<OeChannel> channels_;
  OeOptions options_;
  Eigen::Index p_ = 0, pad_ = 0, n_eq_ = 0;
  int nonlinear_channels_ = 0;
  std::vector<detail::LaggedColumn> columns_;
  std::vector<detail::RowSpan> record_, stretches_, equations_;  // record_: y's own rows
  Eigen::VectorXd y_laid_;
  Eigen::MatrixXd u_laid_;
  Eigen::Vector2d f1_;
  detail::NormalEquationsSolver solver_;
  Eigen::MatrixXd G_, H_, A_;
  Eigen::VectorXd h_, delta_, theta_, candidate_theta_, error_, residual_, unit_;
  Eigen::VectorXd grid_v_, grid_sums_;  // pole_grid_start: interleaved filters, sums
  // Per channel, zero-padded (pad_ leading zeros) so lagged columns may reach t < 0.
  std::vector<Eigen::VectorXd> w_, v_, s_, r_;
  OeResult candidate_;
  // Factored on an empty matrix so copies of an unfitted estimator are defined (UBSan).
  Eigen::LDLT<Eigen::MatrixXd> ldlt_{Eigen::MatrixXd(0, 0)};
  // ArxOeEstimator checks the raw window once and turns the per-call check off.
  bool check_signals_ = true;
  friend class ArxOeEstimator;
};

OeResult oe(const Eigen::Ref<const Eigen::VectorXd>& y, const Eigen::Ref<const Eigen::MatrixXd>& u,
            const std::vector<OeChannel>& channels, Eigen::Index skip = 0,
            const OeOptions& options = {}, const std::vector<Eigen::Index>& stretch_starts = {});

}  // namespace mpmpp
