// lagged_normal_equations and lagged_matrix against the explicit regressor matrix: the
// lag-structure shortcuts (Toeplitz updates of G, h read from G when the target is one of
// the lagged signals) must give Phi'Phi and Phi'y up to rounding, lagged_matrix Phi exactly.
#include <gtest/gtest.h>

#include <cmath>
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

  Eigen::MatrixXd materialised;
  mpmpp::detail::lagged_matrix(columns, t0, n, materialised);
  EXPECT_EQ(materialised, phi);

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
  const std::vector<LaggedColumn> columns = {{w.data(), 0, 1.0},
                                             {w.data(), 1, 1.0},
                                             {v.data(), 1, -1.0},
                                             {v.data(), 2, -1.0},
                                             {w.data(), 3, 1.0}};
  expect_explicit_normal_equations(columns, e.data(), t0, N - t0);
}

}  // namespace

namespace {

// apply_sensitivity is d theta / d h: (G + ridge)^-1 in original coordinates, the ridge being
// delta/2 diag(G) when the rule engages. Checked against a dense solve of that matrix, and
// applied to h itself it must give theta.
void expect_sensitivity_is_the_regularised_inverse(const Eigen::MatrixXd& G,
                                                   const Eigen::VectorXd& h, double delta,
                                                   bool expect_ridge) {
  mpmpp::detail::NormalEquationsSolver solver;
  Eigen::VectorXd theta;
  const auto outcome = solver.solve(G, h, delta, 1e-10, theta);
  ASSERT_EQ(outcome.status, mpmpp::detail::NormalEquationsSolver::Status::Ok);
  EXPECT_EQ(outcome.regularised, expect_ridge);
  Eigen::MatrixXd reg = G;
  if (expect_ridge) reg.diagonal() *= 1.0 + 0.5 * delta;
  Eigen::MatrixXd B(G.rows(), 3);
  for (Eigen::Index i = 0; i < B.size(); ++i) B.data()[i] = std::sin(static_cast<double>(i + 1));
  const Eigen::MatrixXd expected = reg.ldlt().solve(B);
  solver.apply_sensitivity(B);
  EXPECT_LE((B - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff());
  Eigen::MatrixXd H = h;
  solver.apply_sensitivity(H);
  EXPECT_LE((H.col(0) - theta).cwiseAbs().maxCoeff(), 1e-12 * theta.cwiseAbs().maxCoeff());
}

}  // namespace

TEST(NormalEquationsSolver, SensitivityIsTheInverseOfTheSolvedMatrix) {
  const Eigen::Index N = 400, p = 5;
  Eigen::MatrixXd phi(N, p);
  for (Eigen::Index k = 0; k < p; ++k) phi.col(k) = random_signal(N, 10 + static_cast<unsigned>(k));
  const Eigen::VectorXd y = random_signal(N, 20);
  expect_sensitivity_is_the_regularised_inverse(phi.transpose() * phi, phi.transpose() * y, 1e-4,
                                                false);
  // Two nearly collinear columns (scaled lambda_min ~ 1e-6 < delta/2): the ridge engages.
  phi.col(1) = phi.col(0) + 1e-3 * phi.col(1);
  expect_sensitivity_is_the_regularised_inverse(phi.transpose() * phi, phi.transpose() * y, 1e-4,
                                                true);
}
