#pragma once
// High-order MISO ARX, the first step of the paper's ARX-OE method (Section 3.1, eqs.
// (6) and (12)):
//   A(q) y(t) = sum_j q^-d_j B_j(q) u_j(t) + e(t),
//   A(q)   = 1 + a_1 q^-1 + ... + a_na q^-na            (estimate of A_0 = 1 / H_0),
//   B_j(q) = b_j0 + b_j1 q^-1 + ... + b_j,nb_j-1 q^-(nb_j-1)   (estimate of A_0 G_0j).
// nb_j counts coefficients (MATLAB `arx` convention, delay d_j = MATLAB nk): the paper's
// SISO order n = 9 is na = 9, nb = 10. Equations run over t = t0 .. N-1 with
// t0 = max(na, max_j d_j + nb_j - 1), so no sample before the window is assumed.
#include <Eigen/Dense>
#include <vector>

#include "mpmpp/detail/lagged_regression.hpp"

namespace mpmpp {

struct ArxOrders {
  int na = 0;
  std::vector<int> nb;      // per input, >= 1
  std::vector<int> delays;  // per input, >= 0: known delays d_j (from the nominal model)
};

struct ArxOptions {
  // delta of the Section 3.1 rule, applied to the regressor-scaled R (unit diagonal,
  // see NormalEquationsSolver): ridge delta/2 * diag(R) when lambda_min <= delta/2.
  // 1e-4 engages only when a direction of the regressor space carries < 5e-5 of the
  // regressors' energy, i.e. an ill-conditioned window; well-conditioned windows are
  // plain least squares (the paper asks for a "small" delta; asymptotically it does not
  // matter). 0 disables the rule.
  double delta = 1e-4;
  // lambda_min <= rank_tolerance * trace of the scaled R (trace >= lambda_max): collinear
  // regressors, a NumericalError (the window is not informative), never a ridge guess.
  double rank_tolerance = 1e-10;
};

struct ArxResult {
  Eigen::VectorXd a;               // [1, a_1, ..., a_na]
  std::vector<Eigen::VectorXd> b;  // b[j] = [b_j0, ..., b_j,nb_j-1]
  Eigen::VectorXd theta;           // [a_1..a_na, b_1 block, b_2 block, ...]
  Eigen::MatrixXd covariance;      // of theta: sigma^2 R_reg^-1 R R_reg^-1 / N_eq
  double noise_variance = 0.0;     // sum(eps^2) / (N_eq - p)
  Eigen::Index equations = 0;      // N_eq = N - t0
  bool regularised = false;        // the delta/2 ridge was used in this window
};

// Reusable estimator: holds the workspace so that estimating thousands of windows of
// the same orders does not allocate after the first one.
class ArxEstimator {
 public:
  explicit ArxEstimator(ArxOrders orders, ArxOptions options = {});

  // y: the window (N samples), u: N x m (column j = input j); both may be views into a
  // longer series (y.segment(start, N), u.middleRows(start, N)): nothing is copied.
  // InputError on shape/order mismatch; NumericalError when the window is not
  // informative (non-finite samples, too short for the orders, constant signal,
  // collinear regressors).
  // stretch_starts: rows where a new complete stretch of the record begins (after a gap
  // or a missing value); the equations then run over t0 .. of every stretch, so no lag
  // reaches across a gap.
  void estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                const Eigen::Ref<const Eigen::MatrixXd>& u, ArxResult& out,
                const std::vector<Eigen::Index>& stretch_starts = {});
  ArxResult estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                     const Eigen::Ref<const Eigen::MatrixXd>& u,
                     const std::vector<Eigen::Index>& stretch_starts = {});

  const ArxOrders& orders() const { return orders_; }
  Eigen::Index first_equation() const { return t0_; }  // t0
  Eigen::Index num_parameters() const { return p_; }
  // Shortest window the orders allow: at least two equations per parameter
  // (a choice: N_eq = p + 1 would "fit" but give a meaningless noise variance).
  Eigen::Index min_window() const { return t0_ + 2 * p_; }
  // After estimate(): B <- (Phi'Phi + ridge)^-1 B with the window's factorisation (the
  // ridge when ArxResult::regularised): how theta moves with Phi'y.
  void apply_sensitivity(Eigen::MatrixXd& B) const { solver_.apply_sensitivity(B); }
  // After estimate() on one stretch: that window's regressor matrix Phi (rows t0 .. t0 +
  // equations - 1, `equations` = its ArxResult::equations). Reads the y and u given to
  // estimate(), which must still be alive.
  void regressors(Eigen::Index equations, Eigen::MatrixXd& phi) const {
    detail::lagged_matrix(columns_, t0_, equations, phi);
  }

 private:
  ArxOrders orders_;
  ArxOptions options_;
  Eigen::Index t0_ = 0, p_ = 0;
  std::vector<detail::LaggedColumn> columns_;
  detail::NormalEquationsSolver solver_;
  Eigen::MatrixXd G_;
  Eigen::VectorXd h_;
  std::vector<detail::RowSpan> stretches_, equations_;
  // ArxOeEstimator checks the raw window once and turns the per-call check off.
  bool check_signals_ = true;
  friend class ArxOeEstimator;
};

ArxResult arx(const Eigen::Ref<const Eigen::VectorXd>& y,
              const Eigen::Ref<const Eigen::MatrixXd>& u, const ArxOrders& orders,
              const ArxOptions& options = {}, const std::vector<Eigen::Index>& stretch_starts = {});

// Throws NumericalError naming the signal ("y", "u[j]") when the window has non-finite
// samples or a signal that is constant up to rounding (range <= 1e-12 max|x|): such a
// window identifies nothing, and after mean removal its rounding noise would pass for
// a regressor.
void require_informative_window(const Eigen::Ref<const Eigen::VectorXd>& y,
                                const Eigen::Ref<const Eigen::MatrixXd>& u);

}  // namespace mpmpp
