#include "mpmpp/refitted_noise.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {
namespace {

// Lag vector z_t = (x_t, ..., x_{t-order}) with zeros before the start.
void lags(const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Index t, int order, double* z) {
  for (int l = 0; l <= order; ++l) z[l] = t >= l ? x[t - l] : 0.0;
}

// The AR fitted on `fit_gram` (c = (1, -a) minimising c' M c) and its error sums c' M c on
// `fit_gram` and on `score_gram`; false when the lag block is not positive definite. P1 is the
// matrices' fixed size (order + 1) or Eigen::Dynamic.
template <int P1>
bool ar_errors(const Eigen::Matrix<double, P1, P1>& fit_gram,
               const Eigen::Matrix<double, P1, P1>& score_gram, int order, double& fit,
               double& held) {
  constexpr int P = P1 == Eigen::Dynamic ? Eigen::Dynamic : P1 - 1;
  const Eigen::LDLT<Eigen::Matrix<double, P, P>> ldlt(fit_gram.bottomRightCorner(order, order));
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      ldlt.vectorD().minCoeff() <= 1e-14 * std::max(1.0, ldlt.vectorD().maxCoeff()))
    return false;
  Eigen::Matrix<double, P1, 1> c(order + 1);
  c[0] = 1.0;
  c.tail(order) = -ldlt.solve(fit_gram.col(0).tail(order));
  fit = c.dot(fit_gram * c);
  held = c.dot(score_gram * c);
  return fit > 0.0 && held > 0.0;
}

}  // namespace

RefittedNoise::RefittedNoise(const Eigen::Ref<const Eigen::VectorXd>& e,
                             const Eigen::Ref<const Eigen::VectorXd>& fold0,
                             const Eigen::Ref<const Eigen::VectorXd>& fold1,
                             const std::vector<Eigen::Index>& onsets, int order)
    : e_(e), fold_(e.size(), -1), onsets_(onsets), order_(order) {
  const Eigen::Index n = e.size();
  if (order < 1) throw InputError("AR order must be >= 1");
  if (fold0.size() != n || fold1.size() != n)
    throw InputError("fold weights must have the length of the error (" + std::to_string(n) + ")");
  weight_ = fold0 + fold1;
  if (!e.allFinite()) throw InputError("the one-step error must be finite (zero-fill gaps)");
  for (std::size_t k = 0; k < onsets.size(); ++k)
    if (onsets[k] < 0 || onsets[k] >= n || (k > 0 && onsets[k] <= onsets[k - 1]))
      throw InputError("onsets must be increasing sample indices inside the record");
  const int p1 = order + 1;
  for (int f = 0; f < 2; ++f) gram_[f] = Eigen::MatrixXd::Zero(p1, p1);
  Eigen::VectorXd z(p1);
  for (Eigen::Index t = 0; t < n; ++t) {
    if (fold0[t] > 0.0 && fold1[t] > 0.0)
      throw InputError("row " + std::to_string(t) + " lies in both folds");
    fold_[t] = fold0[t] > 0.0 ? 0 : (fold1[t] > 0.0 ? 1 : -1);
    if (fold_[t] < 0) continue;
    lags(e_, t, order, z.data());
    gram_[fold_[t]].noalias() += weight_[t] * z * z.transpose();
    rows_[fold_[t]] += weight_[t];
  }
  for (int f = 0; f < 2; ++f)
    degenerate_ = degenerate_ || !ar_errors<Eigen::Dynamic>(gram_[f], gram_[1 - f], order,
                                                            nominal_fit_[f], nominal_held_[f]);
}

template <int P1>
OnsetGains RefittedNoise::scores(const Eigen::Ref<const Eigen::VectorXd>& psi) const {
  using Square = Eigen::Matrix<double, P1, P1>;
  const int p1 = order_ + 1;
  const Eigen::Index n = e_.size(), m = static_cast<Eigen::Index>(onsets_.size());
  OnsetGains out{Eigen::MatrixXd(m, 2), Eigen::MatrixXd(m, 2)};
  const double minus_inf = -std::numeric_limits<double>::infinity();
  Eigen::Matrix<double, P1, 1> zp(p1), ze(p1);
  // Per fold, the suffix sum of w (z^psi z^psi' - z^e z^psi' - z^psi z^e') from the onset on
  // (upper triangle: it is symmetric), grown one onset block at a time from the end.
  Square suffix[2] = {Square::Zero(p1, p1), Square::Zero(p1, p1)}, gram[2];
  const Square nominal[2] = {gram_[0], gram_[1]};
  for (Eigen::Index k = m - 1; k >= 0; --k) {
    const Eigen::Index end = k + 1 < m ? onsets_[k + 1] : n;
    for (Eigen::Index t = onsets_[k]; t < end; ++t) {
      const int f = fold_[t];
      if (f < 0) continue;
      lags(psi, t, order_, zp.data());
      lags(e_, t, order_, ze.data());
      const double w = weight_[t];
      for (int b = 0; b < p1; ++b) {
        const double wp = w * zp[b], we = w * ze[b];
        for (int a = 0; a <= b; ++a) suffix[f](a, b) += (zp[a] - ze[a]) * wp - zp[a] * we;
      }
    }
    for (int f = 0; f < 2; ++f) {
      gram[f] = nominal[f];
      gram[f] += suffix[f].template selfadjointView<Eigen::Upper>();
    }
    for (int f = 0; f < 2; ++f) {
      double fit = 0.0, held = 0.0;
      if (!degenerate_ && ar_errors<P1>(gram[f], gram[1 - f], order_, fit, held)) {
        out.in_fold(k, f) = rows_[f] * std::log(nominal_fit_[f] / fit);
        out.held_out(k, f) = rows_[1 - f] * std::log(nominal_held_[f] / held);
      } else {
        out.in_fold(k, f) = out.held_out(k, f) = minus_inf;
      }
    }
  }
  return out;
}

OnsetGains RefittedNoise::gains(const Eigen::Ref<const Eigen::VectorXd>& psi) const {
  if (psi.size() != e_.size())
    throw InputError("candidate term must have the length of the error (" +
                     std::to_string(e_.size()) + ")");
  switch (order_ + 1) {  // fixed-size lag matrices for the order diagnose uses
    case 6:
      return scores<6>(psi);
    default:
      return scores<Eigen::Dynamic>(psi);
  }
}

}  // namespace mpmpp
