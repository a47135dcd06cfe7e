#include "mpmpp/arx_oe.hpp"

#include <cmath>

#include "mpmpp/error.hpp"
#include "order_limits.hpp"

namespace mpmpp {

int fir_length_to_one_percent(const TransferFunction& nominal) {
  if (nominal.is_zero()) throw InputError("nominal transfer function is zero: give fir_length");
  for (int n = 4096; n <= 1 << 20; n *= 2) {
    const Eigen::VectorXd g = nominal.impulse(n).cwiseAbs();
    const double threshold = 0.01 * g.maxCoeff();
    Eigen::Index last = n - 1;
    while (g[last] < threshold) --last;
    // Decayed when the last quarter of the computed response stays below the threshold.
    if (last < n - n / 4) return static_cast<int>(last + 1);
  }
  throw InputError(
      "nominal impulse response does not fall below 1% of its peak within 1,000,000 samples "
      "(unstable, or an integrator the FIR features cannot hold: the presets siso and mimo monitor "
      "integrating channels; otherwise give fir_length)");
}

TransferFunction without_integrators(const TransferFunction& g) {
  // A root at z = 1 of den(q^-1) = sum_k a_k q^-k is sum_k a_k = 0; synthetic division by
  // (1 - q^-1) leaves the partial sums c_k = a_0 + ... + a_k.
  Eigen::VectorXd den = g.den();
  while (den.size() > 1 && std::abs(den.sum()) <= 1e-9 * den.cwiseAbs().sum()) {
    Eigen::VectorXd quotient(den.size() - 1);
    double partial = 0.0;
    for (Eigen::Index k = 0; k + 1 < den.size(); ++k) quotient[k] = partial += den[k];
    den = quotient;
  }
  return den.size() == g.den().size() ? g : TransferFunction(g.num(), den, g.delay());
}

int settling_samples(const TransferFunction& g) {
  return fir_length_to_one_percent(without_integrators(g));
}

void detrend_in_place(Eigen::Ref<Eigen::VectorXd> x, Detrend mode) {
  const Eigen::Index n = x.size();
  if (mode == Detrend::None || n == 0) return;
  const double mean = x.mean();
  if (mode == Detrend::Mean || n < 2) {
    x.array() -= mean;
    return;
  }
  // Least-squares line on centred time tc = t - (n-1)/2: slope = sum(tc x) / sum(tc^2).
  const double centre = 0.5 * static_cast<double>(n - 1);
  double sxt = 0.0, stt = 0.0;
  for (Eigen::Index t = 0; t < n; ++t) {
    const double tc = static_cast<double>(t) - centre;
    sxt += tc * x[t];
    stt += tc * tc;
  }
  const double slope = sxt / stt;
  for (Eigen::Index t = 0; t < n; ++t) x[t] -= mean + slope * (static_cast<double>(t) - centre);
}

ArxOeEstimator::ArxOeEstimator(ArxOeConfig config)
    : config_(std::move(config)),
      arx_(config_.arx, config_.arx_options),
      oe_(config_.structures, config_.oe_options) {
  const std::size_t m = config_.arx.nb.size();
  if (config_.structures.size() != m)
    throw InputError("structures must have one entry per input (" + std::to_string(m) + ")");
  if (config_.fir_length.size() != m)
    throw InputError("fir_length must have one entry per input (" + std::to_string(m) + ")");
  for (std::size_t j = 0; j < m; ++j)
    if (config_.fir_length[j] < 1 || config_.fir_length[j] > detail::kMaxLag)
      throw InputError("fir_length[" + std::to_string(j) + "] must be in [1, 1000000], got " +
                       std::to_string(config_.fir_length[j]));
  if (config_.two_step_covariance) TwoStepCovariance::require_fir(config_.structures);
  start_impulse_.resize(m);
  arx_.check_signals_ = false;  // estimate() checks the raw window and the detrended one
  oe_.check_signals_ = false;   // A(q)-filtering a non-constant signal keeps it non-constant
}

void ArxOeEstimator::estimate_arx(const Eigen::Ref<const Eigen::VectorXd>& y,
                                  const Eigen::Ref<const Eigen::MatrixXd>& u, ArxResult& out,
                                  const std::vector<Eigen::Index>& stretch_starts) {
  const Eigen::Index N = y.size(), m = static_cast<Eigen::Index>(config_.structures.size());
  if (u.cols() != m || u.rows() != N)
    throw InputError("u must be " + std::to_string(N) + " x " + std::to_string(m) + ", got " +
                     std::to_string(u.rows()) + " x " + std::to_string(u.cols()));
  if (!stretch_starts.empty() && config_.detrend == Detrend::Linear)
    throw InputError("detrend 'linear' needs one stretch (a line through a record with gaps)");
  if (!stretch_starts.empty() && config_.two_step_covariance)
    throw InputError("the two-step covariance needs one stretch");
  // Checked on the raw window: after mean removal a constant signal is rounding noise.
  require_informative_window(y, u);

  // 1. detrended copies in the reused workspace (the ARX/OE below only take views).
  y_ = y;
  u_ = u;
  detrend_in_place(y_, config_.detrend);
  for (Eigen::Index j = 0; j < m; ++j) detrend_in_place(u_.col(j), config_.detrend);
  // A signal that was a pure line is rounding noise after a linear detrend.
  const auto require_left = [](const auto& raw, const auto& left, const std::string& name) {
    if (left.cwiseAbs().maxCoeff() <= 1e-9 * raw.cwiseAbs().maxCoeff())
      throw NumericalError("window not informative: " + name +
                           " is a pure trend (nothing left after detrending)");
  };
  require_left(y, y_, "y");
  for (Eigen::Index j = 0; j < m; ++j)
    require_left(u.col(j), u_.col(j), "u[" + std::to_string(j) + "]");

  // 2. high-order ARX.
  arx_.estimate(y_, u_, out, stretch_starts);
}

void ArxOeEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                              const Eigen::Ref<const Eigen::MatrixXd>& u, ArxOeResult& out,
                              const std::vector<Eigen::Index>& stretch_starts) {
  estimate_arx(y, u, out.arx, stretch_starts);
  const Eigen::Index N = y.size(), m = static_cast<Eigen::Index>(config_.structures.size());
  const Eigen::VectorXd& a = out.arx.a;
  const int na = config_.arx.na;

  // 3. A(q)-filtered data (A is FIR: numerator a, denominator 1), each stretch from rest.
  yf_.resize(N);
  uf_.resize(N, m);
  detail::stretch_spans(N, stretch_starts, stretches_);
  filter_into(a, one_, 0, stretches_, y_, yf_);
  for (Eigen::Index j = 0; j < m; ++j) filter_into(a, one_, 0, stretches_, u_.col(j), uf_.col(j));

  // 4. OE started from the ARX estimate G_j = q^-d_j B_j / A (impulse after the delay).
  for (Eigen::Index j = 0; j < m; ++j) {
    const int L = oe_.start_impulse_length(static_cast<std::size_t>(j));
    pulse_.setZero(L);
    if (L > 0) pulse_[0] = 1.0;
    start_impulse_[j].resize(L);
    filter_into(out.arx.b[j], a, 0, pulse_, start_impulse_[j]);
  }
  oe_.estimate(yf_, uf_, na, out.oe, &start_impulse_, stretch_starts);
  if (config_.two_step_covariance)
    two_step_.compute(y_, u_, yf_, uf_, arx_, out.arx, config_.structures, out.oe,
                      out.two_step_covariance);
  else
    out.two_step_covariance.resize(0, 0);

  out.noise = a.tail(na);
  out.channels.resize(static_cast<std::size_t>(m));
  for (Eigen::Index j = 0; j < m; ++j) {
    ChannelEstimate& c = out.channels[j];
    c.b = out.oe.b[j];
    c.f = out.oe.f[j];
    c.delay = config_.structures[j].delay;
    c.gain = c.b.sum() / c.f.sum();
    pulse_.setZero(config_.fir_length[j]);
    pulse_[0] = 1.0;
    c.fir.resize(config_.fir_length[j]);
    filter_into(c.b, c.f, c.delay, pulse_, c.fir);
  }
}

ArxOeResult ArxOeEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                                     const Eigen::Ref<const Eigen::MatrixXd>& u,
                                     const std::vector<Eigen::Index>& stretch_starts) {
  ArxOeResult out;
  estimate(y, u, out, stretch_starts);
  return out;
}

std::vector<WindowEstimate> ArxOeEstimator::estimate_windows(
    const Eigen::Ref<const Eigen::VectorXd>& y, const Eigen::Ref<const Eigen::MatrixXd>& u,
    Eigen::Index window, Eigen::Index step) {
  if (window < 1) throw InputError("window must be >= 1 sample");
  if (step < 1) throw InputError("step must be >= 1 sample");
  if (u.rows() != y.size())
    throw InputError("u must have as many rows as y has samples (" + std::to_string(y.size()) +
                     "), got " + std::to_string(u.rows()));
  std::vector<WindowEstimate> windows;
  if (y.size() >= window) windows.reserve(static_cast<std::size_t>((y.size() - window) / step + 1));
  for (Eigen::Index s = 0; s + window <= y.size(); s += step) {
    WindowEstimate& w = windows.emplace_back();
    w.start = s;
    try {
      estimate(y.segment(s, window), u.middleRows(s, window), w.result);
      w.ok = true;
    } catch (const NumericalError& e) {
      w.message = e.what();
    }
  }
  return windows;
}

}  // namespace mpmpp
