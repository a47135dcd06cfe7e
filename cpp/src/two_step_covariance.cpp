#include "mpmpp/two_step_covariance.hpp"

#include <algorithm>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

// column(r) = x(first + r - lag), zero before the window (the estimators' zero initial state).
void fill_lagged(Eigen::Ref<Eigen::VectorXd> column, const Eigen::Ref<const Eigen::VectorXd>& x,
                 Eigen::Index first, Eigen::Index lag) {
  const Eigen::Index zeros = std::min(column.size(), std::max<Eigen::Index>(0, lag - first));
  column.head(zeros).setZero();
  column.tail(column.size() - zeros) = x.segment(first + zeros - lag, column.size() - zeros);
}

// The FIR lags of every input (channel blocks in oe.theta's order) for rows t = first..N-1.
void fill_fir_lags(Eigen::MatrixXd& out, const Eigen::Ref<const Eigen::MatrixXd>& u,
                   const std::vector<OeChannel>& fir, Eigen::Index first) {
  out.resize(u.rows() - first, out.cols());
  Eigen::Index c = 0;
  for (std::size_t j = 0; j < fir.size(); ++j)
    for (int i = 0; i < fir[j].nb; ++i, ++c)
      fill_lagged(out.col(c), u.col(static_cast<Eigen::Index>(j)), first, fir[j].delay + i);
}

}  // namespace

void TwoStepCovariance::require_fir(const std::vector<OeChannel>& channels) {
  for (const OeChannel& c : channels)
    if (c.nf != 0)
      throw InputError("two_step_covariance needs FIR structures (nf = 0) for every input");
}

void TwoStepCovariance::compute(const Eigen::Ref<const Eigen::VectorXd>& y,
                                const Eigen::Ref<const Eigen::MatrixXd>& u,
                                const Eigen::Ref<const Eigen::VectorXd>& yf,
                                const Eigen::Ref<const Eigen::MatrixXd>& uf,
                                const ArxEstimator& arx_estimator, const ArxResult& arx,
                                const std::vector<OeChannel>& fir, const OeResult& oe,
                                Eigen::MatrixXd& covariance) {
  require_fir(fir);
  const Eigen::Index N = y.size(), na = arx_estimator.orders().na, p2 = oe.theta.size();
  const Eigen::Index t0 = arx_estimator.first_equation();
  if (N - na <= p2) throw NumericalError("two-step covariance: window too short for the orders");

  // ARX step: its regressors phi_t (rows t >= t0) and residual e.
  arx_estimator.regressors(arx.equations, phi_);
  e_.noalias() = y.tail(N - t0) - phi_ * arx.theta;

  // OE step: filtered lags z_t and residual eps for t >= na; unfiltered lags from t = 0.
  z_.resize(N - na, p2);
  zraw_.resize(N, p2);
  fill_fir_lags(z_, uf, fir, na);
  fill_fir_lags(zraw_, u, fir, 0);
  eps_.noalias() = yf.tail(N - na) - z_ * oe.theta;
  vhat_.noalias() = y - zraw_ * oe.theta;

  // M21 on the a_k columns (the b columns are zero; they stay implicit), as two products
  // with lag matrices: vhat_lags(t - na, k-1) = vhat(t - k) for t >= na, and
  // eps_leads(s, k-1) = eps(s + k) (zero outside t = s + k in [na, N)).
  vhat_lags_.resize(N - na, na);
  eps_leads_.setZero(N, na);
  for (Eigen::Index k = 1; k <= na; ++k) {
    vhat_lags_.col(k - 1) = vhat_.segment(na - k, N - na);
    eps_leads_.col(k - 1).segment(na - k, N - na) = eps_;
  }
  m21_.noalias() = z_.transpose() * vhat_lags_;
  m21_.noalias() += zraw_.transpose() * eps_leads_;

  // x = (Phi'Phi)^-1 [M21'; 0]: the ARX estimate's error mapped into theta2's equations.
  x_.setZero(arx.theta.size(), p2);
  x_.topRows(na) = m21_.transpose();
  arx_estimator.apply_sensitivity(x_);

  w_ = (z_.array().colwise() * eps_.array()).matrix();
  phi_.array().colwise() *= e_.array();
  w_.bottomRows(N - t0).noalias() += phi_ * x_;

  llt_.compute(z_.transpose() * z_);
  if (llt_.info() != Eigen::Success)
    throw NumericalError("two-step covariance: OE regressors are singular");
  zz_inv_ = llt_.solve(Eigen::MatrixXd::Identity(p2, p2));
  const double dof = static_cast<double>(N - na) / static_cast<double>(N - na - p2);
  covariance.noalias() = dof * (zz_inv_ * (w_.transpose() * w_) * zz_inv_);
}

}  // namespace mpmpp
