#include "mpmpp/detail/lagged_regression.hpp"

#include <cmath>

namespace mpmpp::detail {

namespace {
using ConstSegment = Eigen::Map<const Eigen::VectorXd>;

ConstSegment column_segment(const LaggedColumn& c, Eigen::Index t0, Eigen::Index n) {
  return ConstSegment(c.signal + (t0 - c.lag), n);
}
}  // namespace

void lagged_matrix(const std::vector<LaggedColumn>& columns, Eigen::Index t0, Eigen::Index n,
                   Eigen::MatrixXd& phi) {
  phi.resize(n, static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    const LaggedColumn& c = columns[k];
    phi.col(static_cast<Eigen::Index>(k)) = c.sign * ConstSegment(c.signal + t0 - c.lag, n);
  }
}

void lagged_normal_equations(const std::vector<LaggedColumn>& columns, const double* target,
                             Eigen::Index t0, Eigen::Index n, Eigen::MatrixXd& G,
                             Eigen::VectorXd& h) {
  const Eigen::Index p = static_cast<Eigen::Index>(columns.size());
  G.resize(p, p);
  h.resize(p);
  // Column k continues column k-1 when it is the same signal one lag further.
  const auto continues = [&columns](Eigen::Index k) {
    if (k == 0) return false;
    const LaggedColumn &c = columns[k], &prev = columns[k - 1];
    return c.signal == prev.signal && c.lag == prev.lag + 1 && c.sign == prev.sign;
  };
  // ARX regresses the target on its own lags: when a column is the target at lag 1,
  // h is (mostly) already in G, see below.
  Eigen::Index target_lag1 = -1;
  for (Eigen::Index i = 0; i < p && target_lag1 < 0; ++i)
    if (columns[i].signal == target && columns[i].lag == 1) target_lag1 = i;
  const ConstSegment y(target + t0, n);
  // Runs of columns continuing each other (one signal at consecutive lags). An entry
  // G(i, j) (j <= i) needs a dot product only when i or j starts a run: per pair of
  // runs (a, b) the first column of their block, x_i . x_{b0} for every i in a, and
  // its first row, x_{a0} . x_j. A run's columns are overlapping views of one signal
  // (a Hankel matrix, column c at offset c), so each batch is one matrix-vector
  // product that reads x_{b0} (or x_{a0}) once for all its columns.
  struct Run {
    Eigen::Index first, length;
  };
  thread_local std::vector<Run> runs;
  thread_local Eigen::VectorXd batch;
  runs.clear();
  for (Eigen::Index k = 0; k < p; ++k) {
    if (continues(k))
      ++runs.back().length;
    else
      runs.push_back({k, 1});
  }
  // Columns first + skip .. first + length - 1 of a run, the last lag first.
  const auto hankel = [&](const Run& r, Eigen::Index skip) {
    const LaggedColumn& c = columns[r.first];
    const Eigen::Index last_lag = c.lag + r.length - 1;
    return Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>(
        c.signal + t0 - last_lag, n, r.length - skip, Eigen::OuterStride<>(1));
  };
  for (std::size_t ia = 0; ia < runs.size(); ++ia) {
    const Run& a = runs[ia];
    const LaggedColumn& ca = columns[a.first];
    for (std::size_t ib = 0; ib <= ia; ++ib) {
      const Run& b = runs[ib];
      const LaggedColumn& cb = columns[b.first];
      const double s = ca.sign * cb.sign;
      batch.noalias() = hankel(a, 0).transpose() * column_segment(cb, t0, n);
      for (Eigen::Index m = 0; m < a.length; ++m)
        G(a.first + m, b.first) = s * batch[a.length - 1 - m];
      if (ib == ia) continue;
      batch.noalias() = hankel(b, 1).transpose() * column_segment(ca, t0, n);
      for (Eigen::Index m = 1; m < b.length; ++m)
        G(a.first, b.first + m) = s * batch[b.length - 1 - m];
    }
  }
  for (Eigen::Index i = 0; i < p; ++i) {
    const LaggedColumn& ci = columns[i];
    const bool ci_continues = continues(i);
    for (Eigen::Index j = 0; j <= i; ++j) {
      const LaggedColumn& cj = columns[j];
      if (ci_continues && continues(j)) {
        // Both columns shift by one lag against (i-1, j-1): the sum over the rows
        // gains the term at t0 and loses the one at t0 + n (Toeplitz recursion),
        // O(1) instead of an O(n) dot product.
        const double enter = ci.signal[t0 - ci.lag] * cj.signal[t0 - cj.lag];
        const double leave = ci.signal[t0 + n - ci.lag] * cj.signal[t0 + n - cj.lag];
        G(i, j) = G(i - 1, j - 1) + ci.sign * cj.sign * (enter - leave);
      }
      G(j, i) = G(i, j);
    }
  }
  for (Eigen::Index i = 0; i < p; ++i) {
    const LaggedColumn& ci = columns[i];
    if (target_lag1 >= 0 && i + 1 < p && continues(i + 1)) {
      // sum_t x(t - l) y(t) is the sum_t x(t - l - 1) y(t - 1) of G(i + 1, target_lag1)
      // over rows shifted by one: gain the row t0 + n - 1, lose the row t0 - 1 (both
      // readable: column i + 1 reaches x(t0 - l - 1), the lag-1 column y(t0 - 1)).
      const double shifted =
          G(i + 1, target_lag1) * columns[i + 1].sign * columns[target_lag1].sign;
      const double enter = ci.signal[t0 + n - 1 - ci.lag] * target[t0 + n - 1];
      const double leave = ci.signal[t0 - 1 - ci.lag] * target[t0 - 1];
      h[i] = ci.sign * (shifted + enter - leave);
    } else {
      h[i] = ci.sign * column_segment(ci, t0, n).dot(y);
    }
  }
}

bool NormalEquationsSolver::positive_definite_above(double shift) {
  shifted_ = scaled_;
  shifted_.diagonal().array() -= shift;
  llt_.compute(shifted_);
  return llt_.info() == Eigen::Success;
}

NormalEquationsSolver::Outcome NormalEquationsSolver::solve(const Eigen::MatrixXd& G,
                                                            const Eigen::VectorXd& h, double delta,
                                                            double rank_tolerance,
                                                            Eigen::VectorXd& theta) {
  Outcome out;
  const Eigen::Index p = G.rows();
  scale_.resize(p);
  for (Eigen::Index k = 0; k < p; ++k) {
    // A regressor with no energy: an input that is zero over the equations.
    if (!(G(k, k) > 0.0)) {
      out.status = Status::ZeroColumn;
      out.zero_column = k;
      return out;
    }
    scale_[k] = 1.0 / std::sqrt(G(k, k));
  }
  scaled_ = scale_.asDiagonal() * G * scale_.asDiagonal();
  // Section 3.1: ||Rs^-1||_2 >= 2/delta  <=>  lambda_min(Rs) <= delta/2. When
  // delta/2 >= the collinearity bound, lambda_min > delta/2 also rules out collinear
  // regressors: the usual well-conditioned window needs one test factorisation, not two.
  const double collinear = rank_tolerance * static_cast<double>(p), rule = 0.5 * delta;
  bool above_rule = delta > 0.0 && rule >= collinear && positive_definite_above(rule);
  if (!above_rule) {
    if (!positive_definite_above(collinear)) {
      out.status = Status::Singular;
      return out;
    }
    if (delta > 0.0 && rule < collinear) above_rule = positive_definite_above(rule);
  }
  out.regularised = delta > 0.0 && !above_rule;
  shift_ = out.regularised ? 0.5 * delta : 0.0;
  positive_definite_above(-shift_);  // factor of Rs + shift I (positive definite here)
  theta = llt_.solve(scale_.cwiseProduct(h));
  theta.array() *= scale_.array();
  return out;
}

void NormalEquationsSolver::apply_sensitivity(Eigen::MatrixXd& B) const {
  B = scale_.asDiagonal() * B;
  llt_.solveInPlace(B);
  B = scale_.asDiagonal() * B;
}

void NormalEquationsSolver::covariance_factor(Eigen::MatrixXd& C) const {
  // theta = S (Rs + cI)^-1 S h and cov(h) = sigma^2 G = sigma^2 S^-1 Rs S^-1 give
  // cov(theta) = sigma^2 S (Rs + cI)^-1 Rs (Rs + cI)^-1 S.
  // (Rs + cI)^-1 = L^-T L^-1 from the Cholesky factor, by plain loops: for these small p
  // (tens) Eigen's blocked triangular solve with an identity right-hand side spends
  // several times the ~p^3/3 multiply-adds on blocking and packing.
  const Eigen::Index p = scaled_.rows();
  const Eigen::MatrixXd& L = llt_.matrixLLT();  // L in the lower triangle
  Eigen::MatrixXd& Li = inverse_factor_;
  Li.setZero(p, p);
  for (Eigen::Index j = 0; j < p; ++j) {  // column j of L^-1 by forward substitution
    Li(j, j) = 1.0 / L(j, j);
    for (Eigen::Index i = j + 1; i < p; ++i)
      Li(i, j) = -L.row(i).segment(j, i - j).dot(Li.col(j).segment(j, i - j)) / L(i, i);
  }
  C.resize(p, p);
  for (Eigen::Index j = 0; j < p; ++j)
    for (Eigen::Index i = j; i < p; ++i)  // (L^-T L^-1)(i, j) = sum_{k >= i} Li(k, i) Li(k, j)
      C(i, j) = C(j, i) = Li.col(i).tail(p - i).dot(Li.col(j).tail(p - i));
  if (shift_ > 0.0) C = (C * scaled_ * C).eval();
  C = scale_.asDiagonal() * C * scale_.asDiagonal();
}

void lagged_normal_equations(const std::vector<LaggedColumn>& columns, const double* target,
                             const std::vector<RowSpan>& spans, Eigen::MatrixXd& G,
                             Eigen::VectorXd& h) {
  if (spans.size() == 1) {  // one window: no sums to add (the detectors' hot path)
    lagged_normal_equations(columns, target, spans[0].begin, spans[0].size(), G, h);
    return;
  }
  const Eigen::Index p = static_cast<Eigen::Index>(columns.size());
  thread_local Eigen::MatrixXd G_span;
  thread_local Eigen::VectorXd h_span;
  G.setZero(p, p);
  h.setZero(p);
  for (const RowSpan& s : spans) {
    if (s.size() <= 0) continue;
    lagged_normal_equations(columns, target, s.begin, s.size(), G_span, h_span);
    G += G_span;
    h += h_span;
  }
}

}  // namespace mpmpp::detail
