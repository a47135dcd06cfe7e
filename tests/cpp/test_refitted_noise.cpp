// RefittedNoise against an explicit least-squares AR fit: for each onset and fold, the AR of
// x = e - 1[t >= onset] psi fitted by QR on one fold's lag rows, its squared error on both
// folds, and the statistics n log(SSE_nominal / SSE_candidate) built from them.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mpmpp/refitted_noise.hpp"

namespace {

// Squared-error sums (train, test) of the AR(order) of x = e - 1[t >= onset] psi fitted on the
// rows with train weight > 0 (lag vectors with zeros before the start, as the kernel defines).
std::pair<double, double> explicit_fit(const Eigen::VectorXd& e, const Eigen::VectorXd& psi,
                                       Eigen::Index onset, const Eigen::VectorXd& train,
                                       const Eigen::VectorXd& test, int order) {
  const Eigen::Index n = e.size();
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(n, order + 1);
  for (Eigen::Index t = 0; t < n; ++t)
    for (int l = 0; l <= order && l <= t; ++l) z(t, l) = e[t - l] - (t >= onset ? psi[t - l] : 0.0);
  Eigen::Index rows = 0;
  for (Eigen::Index t = 0; t < n; ++t) rows += train[t] > 0;
  Eigen::MatrixXd a_rows(rows, order);
  Eigen::VectorXd b_rows(rows);
  for (Eigen::Index t = 0, r = 0; t < n; ++t)
    if (train[t] > 0) {
      a_rows.row(r) = z.row(t).tail(order);
      b_rows[r++] = z(t, 0);
    }
  const Eigen::VectorXd a = a_rows.colPivHouseholderQr().solve(b_rows);
  const Eigen::VectorXd resid = z.col(0) - z.rightCols(order) * a;
  return {(resid.array().square() * train.array()).sum(),
          (resid.array().square() * test.array()).sum()};
}

TEST(RefittedNoise, MatchesExplicitLeastSquaresArFits) {
  const Eigen::Index n = 2000;
  std::mt19937 gen(3);
  std::normal_distribution<double> nd(0.0, 1.0);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(n), psi(n), fold0(n), fold1(n);
  for (Eigen::Index t = 0; t < n; ++t) {
    psi[t] = std::sin(t / 9.0) + 0.2 * nd(gen);
    e[t] = (t >= 2 ? 1.1 * e[t - 1] - 0.4 * e[t - 2] : 0.0) + nd(gen) + (t >= 1200 ? psi[t] : 0.0);
    const bool odd = (t / 200) % 2;
    fold0[t] = t >= 40 && !odd;
    fold1[t] = t >= 40 && odd;
  }
  const std::vector<Eigen::Index> onsets = {0, 400, 1200, 1600};
  for (int order : {5, 2}) {
    const mpmpp::OnsetGains g = mpmpp::RefittedNoise(e, fold0, fold1, onsets, order).gains(psi);
    const Eigen::VectorXd* folds[2] = {&fold0, &fold1};
    for (std::size_t k = 0; k < onsets.size(); ++k)
      for (int f = 0; f < 2; ++f) {
        const auto nominal =
            explicit_fit(e, Eigen::VectorXd::Zero(n), n, *folds[f], *folds[1 - f], order);
        const auto cand = explicit_fit(e, psi, onsets[k], *folds[f], *folds[1 - f], order);
        EXPECT_NEAR(g.in_fold(k, f), folds[f]->sum() * std::log(nominal.first / cand.first), 1e-6);
        EXPECT_NEAR(g.held_out(k, f), folds[1 - f]->sum() * std::log(nominal.second / cand.second),
                    1e-6);
      }
    // the term switched on at 1200 explains most there
    Eigen::Index best;
    g.held_out.rowwise().sum().maxCoeff(&best);
    EXPECT_EQ(best, 2);
  }
}

}  // namespace
