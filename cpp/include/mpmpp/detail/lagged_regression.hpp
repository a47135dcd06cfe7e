#pragma once
// Least squares whose regressors are lagged copies of a few signals (ARX, FIR, the
// Gauss-Newton steps of OE). The regressor matrix is never formed: every column is a
// shifted view of a signal, so the normal equations are dot products of segments of
// the caller's arrays (no copy of the data per window).
#include <Eigen/Dense>
#include <vector>

#include "mpmpp/detail/row_spans.hpp"

namespace mpmpp::detail {

// Column k of Phi: Phi(t, k) = sign * signal[t - lag] for rows t in [t0, t0 + n).
// `signal` points at sample 0; the caller guarantees signal[t0 - lag .. t0 + n - lag)
// is readable (zero-padded history where the model assumes zero initial state).
struct LaggedColumn {
  const double* signal;
  Eigen::Index lag;
  double sign;
};

// Phi itself, rows t0 .. t0 + n - 1 (for the callers that need per-row products).
void lagged_matrix(const std::vector<LaggedColumn>& columns, Eigen::Index t0, Eigen::Index n,
                   Eigen::MatrixXd& phi);
// G = Phi^T Phi and h = Phi^T target[t0 .. t0 + n) (G, h resized only when p changes).
void lagged_normal_equations(const std::vector<LaggedColumn>& columns, const double* target,
                             Eigen::Index t0, Eigen::Index n, Eigen::MatrixXd& G,
                             Eigen::VectorXd& h);
// The same summed over the rows of every span (spans of a record of several stretches: a
// column's lags must stay readable before each span's first row).
void lagged_normal_equations(const std::vector<LaggedColumn>& columns, const double* target,
                             const std::vector<RowSpan>& spans, Eigen::MatrixXd& G,
                             Eigen::VectorXd& h);

// Solves the normal equations R theta = f with R = G / n, f = h / n, in the
// regressor-scaled coordinates Rs = S R S, S = diag(R)^-1/2 (unit-free: y and every u_j
// may have any engineering unit). Section 3.1 regularisation rule applied to Rs:
//   use Rs + delta/2 I when ||Rs^-1||_2 = 1/lambda_min(Rs) >= 2/delta, else Rs;
// delta = 0 disables it. The rule is decided without an eigendecomposition:
// lambda_min(Rs) > delta/2 exactly when Rs - delta/2 I has a Cholesky factor.
class NormalEquationsSolver {
 public:
  enum class Status { Ok, ZeroColumn, Singular };
  struct Outcome {
    Status status = Status::Ok;
    Eigen::Index zero_column = -1;  // the first identically-zero regressor (ZeroColumn)
    bool regularised = false;
  };

  // rank_tolerance: lambda_min(Rs) <= rank_tolerance * trace(Rs) (trace(Rs) = p bounds
  // lambda_max from above) means exactly collinear regressors, i.e. the data do not
  // identify the model: Status::Singular.
  Outcome solve(const Eigen::MatrixXd& G, const Eigen::VectorXd& h, double delta,
                double rank_tolerance, Eigen::VectorXd& theta);
  // Unscaled (sum-form) covariance factor C with cov(theta) = sigma^2 C after solve():
  // S (Rs + cI)^-1 Rs (Rs + cI)^-1 S, the sandwich form that reduces to G^-1 when c = 0.
  void covariance_factor(Eigen::MatrixXd& C) const;
  // After solve(): B <- (d theta / d h) B = S (Rs + cI)^-1 S B, i.e. (G + ridge)^-1 B, how
  // theta moves with the right-hand side (the influence a two-step covariance needs).
  void apply_sensitivity(Eigen::MatrixXd& B) const;

 private:
  // True when Rs - shift I is positive definite (leaves its factor in llt_).
  bool positive_definite_above(double shift);

  Eigen::VectorXd scale_;
  Eigen::MatrixXd scaled_, shifted_;
  mutable Eigen::MatrixXd inverse_factor_;  // covariance_factor's workspace: L^-1
  // Factored once on an empty matrix so that copying a solver that has not solved yet
  // copies a defined state (a default LLT leaves its info flag uninitialised: UBSan).
  Eigen::LLT<Eigen::MatrixXd> llt_{Eigen::MatrixXd(0, 0)};
  double shift_ = 0.0;
};

}  // namespace mpmpp::detail
