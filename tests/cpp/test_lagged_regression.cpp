// lagged_normal_equations against the explicit regressor matrix: the lag-structure
// shortcuts (Toeplitz updates of G, h read from G when the target is one of the lagged
// signals) must give Phi'Phi and Phi'y up to rounding.
#include <gtest/gtest.h>

#include <random>

#include "mpmpp/detail/lagged_regression.hpp"

namespace {

using mpmpp::detail::LaggedColumn;

Eigen::VectorXd random_signal(Eigen::Index n, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> nd(0.3, 1.0);
  Eigen::VectorXd x(n);
  for (Eigen::Index t = 0; t < n; ++t) x[t] = nd(gen);
  return x;
}

void expect_explicit_normal_equations(const std::vector<LaggedColumn>& columns,
                                      const double* target, Eigen::Index t0, Eigen::Index n) {
  const Eigen::Index p = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd phi(n, p);
  for (Eigen::Index k = 0; k < p; ++k)
    for (Eigen::Index r = 0; r < n; ++r)
      phi(r, k) = columns[k].sign * columns[k].signal[t0 + r - columns[k].lag];
  const Eigen::Map<const Eigen::VectorXd> y(target + t0, n);
  const Eigen::MatrixXd G_ref = phi.transpose() * phi;
  const Eigen::VectorXd h_ref = phi.transpose() * y;

  Eigen::MatrixXd G;
  Eigen::VectorXd h;
  mpmpp::detail::lagged_normal_equations(columns, target, t0, n, G, h);
  const double scale = G_ref.cwiseAbs().maxCoeff();
  EXPECT_LE((G - G_ref).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_LE((h - h_ref).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_TRUE(G.isApprox(G.transpose(), 0.0));
}

TEST(LaggedNormalEquations, ArxColumnsWithTheTargetAmongTheSignalsMatchPhiTransposePhi) {
  // MISO ARX(na = 4; nb = 3, 2; d = 2, 0): y lags 1..4 (sign -1), u_j lags d_j..d_j+nb_j-1.
  const Eigen::Index N = 300, t0 = 4;
  const Eigen::VectorXd y = random_signal(N, 1), u1 = random_signal(N, 2), u2 = random_signal(N, 3);
  std::vector<LaggedColumn> columns;
  for (int k = 1; k <= 4; ++k) columns.push_back({y.data(), k, -1.0});
  for (int k = 2; k <= 4; ++k) columns.push_back({u1.data(), k, 1.0});
  for (int k = 0; k <= 1; ++k) columns.push_back({u2.data(), k, 1.0});
  expect_explicit_normal_equations(columns, y.data(), t0, N - t0);
  // A shorter range inside the signal (rows after t0 + n exist but are not used).
  expect_explicit_normal_equations(columns, y.data(), t0 + 7, N - t0 - 30);
}

TEST(LaggedNormalEquations, ColumnsUnrelatedToTheTargetMatchPhiTransposePhi) {
  const Eigen::Index N = 200, t0 = 3;
  const Eigen::VectorXd w = random_signal(N, 4), v = random_signal(N, 5), e = random_signal(N, 6);
  const std::vector<LaggedColumn> columns = {
      {w.data(), 0, 1.0}, {w.data(), 1, 1.0}, {v.data(), 1, -1.0}, {v.data(), 2, -1.0}, {w.data(), 3, 1.0}};
  expect_explicit_normal_equations(columns, e.data(), t0, N - t0);
}

}  // namespace
