#include "mpmpp/output_error.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <string>

#include "mpmpp/arx.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/transfer_function.hpp"
#include "order_limits.hpp"

namespace mpmpp {

OutputErrorEstimator::OutputErrorEstimator(std::vector<OeChannel> channels, OeOptions options)
    : channels_(std::move(channels)), options_(options) {
  if (channels_.empty()) throw InputError("channels must name at least one input");
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const auto& c = channels_[j];
    const std::string at = "channels[" + std::to_string(j) + "]";
    if (c.nb < 1) throw InputError(at + ".nb must be >= 1, got " + std::to_string(c.nb));
    if (c.nf < 0) throw InputError(at + ".nf must be >= 0, got " + std::to_string(c.nf));
    if (c.delay < 0) throw InputError(at + ".delay must be >= 0, got " + std::to_string(c.delay));
    const auto at_most_max_lag = [&](const char* name, int value) {
      if (value > detail::kMaxLag)
        throw InputError(at + name + " must be <= 1000000, got " + std::to_string(value));
    };
    at_most_max_lag(".nb", c.nb);
    at_most_max_lag(".nf", c.nf);
    at_most_max_lag(".delay", c.delay);
    p_ += Eigen::Index{c.nb} + c.nf;
    if (c.nf > 0) ++nonlinear_channels_;
  }
  if (options_.max_iterations < 1) throw InputError("max_iterations must be >= 1");
  if (!(options_.max_pole_radius > 0.0 && options_.max_pole_radius < 1.0))
    throw InputError("max_pole_radius must be in (0, 1)");
  if (options_.init_fir_length < 0 || options_.init_fir_length > detail::kMaxLag)
    throw InputError("init_fir_length must be in [0, 1000000]");
  const std::size_t m = channels_.size();
  w_.resize(m);
  v_.resize(m);
  s_.resize(m);
  r_.resize(m);
  unit_ = Eigen::VectorXd::Ones(1);
}

int OutputErrorEstimator::start_impulse_length(std::size_t j) const {
  const OeChannel& c = channels_[j];
  if (c.nf == 0) return c.nb;
  return options_.init_fir_length > 0 ? options_.init_fir_length : std::max(30, c.nb + c.nf + 10);
}

int OutputErrorEstimator::init_fir_length(std::size_t j, Eigen::Index n_eq) const {
  if (channels_[j].nf == 0) return channels_[j].nb;
  int linear_coefficients = 0;
  for (const auto& other : channels_)
    if (other.nf == 0) linear_coefficients += other.nb;
  // Keep >= 4 equations per FIR coefficient in the joint start fit.
  const Eigen::Index budget = (n_eq / 4 - linear_coefficients) / nonlinear_channels_;
  return static_cast<int>(std::clamp<Eigen::Index>(budget, 0, start_impulse_length(j)));
}

void OutputErrorEstimator::unpack(const Eigen::VectorXd& theta, OeResult& par) const {
  Eigen::Index k = 0;
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const auto& c = channels_[j];
    par.b[j] = theta.segment(k, c.nb);
    k += c.nb;
    par.f[j].resize(c.nf + 1);
    par.f[j][0] = 1.0;
    par.f[j].tail(c.nf) = theta.segment(k, c.nf);
    k += c.nf;
  }
}

void OutputErrorEstimator::pack(const OeResult& par, Eigen::VectorXd& theta) const {
  theta.resize(p_);
  Eigen::Index k = 0;
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const auto& c = channels_[j];
    theta.segment(k, c.nb) = par.b[j];
    k += c.nb;
    theta.segment(k, c.nf) = par.f[j].tail(c.nf);
    k += c.nf;
  }
}

void OutputErrorEstimator::stabilise(Eigen::VectorXd& f) const {
  const double rmax = options_.max_pole_radius;
  const Eigen::Index nf = f.size() - 1;
  if (nf == 0) return;
  // Reflect z -> 1/conj(z) (same magnitude response up to a gain) and cap the radius.
  const auto project = [rmax](std::complex<double> z) {
    if (std::abs(z) > 1.0) z = 1.0 / std::conj(z);
    if (std::abs(z) > rmax) z *= rmax / std::abs(z);
    return z;
  };
  if (nf == 1) {  // root z = -f1: no eigenvalue problem on the hot path
    if (std::abs(f[1]) > rmax) f[1] = -project(-f[1]).real();
    return;
  }
  const Eigen::VectorXcd roots = poly_roots(f);
  if (roots.size() == 0 || roots.cwiseAbs().maxCoeff() <= rmax) return;
  Eigen::VectorXcd c = Eigen::VectorXcd::Zero(nf + 1);
  c[0] = 1.0;
  for (Eigen::Index r = 0; r < roots.size(); ++r) {  // c *= (1 - z_r q^-1)
    const std::complex<double> z = project(roots[r]);
    for (Eigen::Index k = r + 1; k >= 1; --k) c[k] -= z * c[k - 1];
  }
  f = c.real();  // trailing zero coefficients (roots at the origin) stay zero
}

void OutputErrorEstimator::prony_start(std::size_t j, const Eigen::Ref<const Eigen::VectorXd>& g,
                                       Eigen::VectorXd& b, Eigen::VectorXd& f) const {
  // F(q) G(q) = B(q): for k >= nb, g_k + sum_i f_i g_{k-i} = 0 (least squares in f),
  // then b_k = g_k + sum_i f_i g_{k-i} for k < nb (Kalman's / Prony's method).
  const int nb = channels_[j].nb, nf = channels_[j].nf;
  const Eigen::Index L = g.size();
  const auto at = [&g](Eigen::Index k) { return k >= 0 && k < g.size() ? g[k] : 0.0; };
  f = Eigen::VectorXd::Zero(nf + 1);
  f[0] = 1.0;
  if (nf > 0 && L - nb >= nf) {
    Eigen::MatrixXd M(L - nb, nf);
    Eigen::VectorXd rhs(L - nb);
    for (Eigen::Index k = nb; k < L; ++k) {
      rhs[k - nb] = -g[k];
      for (int i = 1; i <= nf; ++i) M(k - nb, i - 1) = at(k - i);
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(M);
    // A rank-deficient M (e.g. a zero impulse response) keeps F = 1: poles at the origin.
    if (qr.rank() == nf) f.tail(nf) = qr.solve(rhs);
    stabilise(f);
  }
  b.resize(nb);
  for (int k = 0; k < nb; ++k) {
    double s = at(k);
    for (int i = 1; i <= std::min(k, nf); ++i) s += f[i] * at(k - i);
    b[k] = s;
  }
}

void OutputErrorEstimator::pole_grid_start(std::size_t j,
                                           const Eigen::Ref<const Eigen::MatrixXd>& u,
                                           const double* y, Eigen::Index N, OeResult& out) {
  // A Prony fit to a noisy impulse response is pulled towards a pole at 0 (noise in the
  // taps inflates its denominator), and the OE cost has a poor valley between fast and
  // slow poles. For a first-order denominator the cost over the pole is one-dimensional
  // once b_j is eliminated by least squares (other channels held), so a few poles are
  // tried and Levenberg-Marquardt starts from the best: Prony's pole or a grid point.
  static constexpr double kGrid[] = {-0.5, 0.0, 0.5, 0.8, 0.9, 0.95, 0.98};
  constexpr int P = static_cast<int>(std::size(kGrid)) + 1;  // Prony's pole first
  const OeChannel& ch = channels_[j];
  const int nb = ch.nb;
  // Target for channel j: the data minus the other channels' simulation (none: SISO).
  if (channels_.size() == 1) {
    residual_ = Eigen::Map<const Eigen::VectorXd>(y, N);
  } else {
    simulate(u, y, N, out);
    residual_ = error_;
    for (Eigen::Index k = 0; k < nb; ++k)
      residual_ += out.b[j][k] * Eigen::Map<const Eigen::VectorXd>(w_[j].data() + pad_ - k, N);
  }
  const double rr = criterion_sum_of_squares(residual_);

  std::array<double, P> pole;
  pole[0] = -out.f[j][1];
  for (int g = 1; g < P; ++g) pole[g] = std::min(kGrid[g - 1], options_.max_pole_radius);
  // The P filters v_g = q^-d / (1 - pole_g q^-1) u_j in one pass, interleaved (row t of
  // grid_v_ is v_g(t) for every g: independent recursions side by side vectorise, where
  // one filter at a time is a chain of dependent multiply-adds), then the
  // least-squares sums in b_j of all P poles together, again vectorised across poles:
  //   G_g(k, l) = sum_{equations} v_g(t - k) v_g(t - l),  h_g(k) = sum v_g(t - k) residual(t).
  // Each stretch starts at rest: v_g = 0 in the nb rows before the first and in the
  // pad_ >= nb rows between stretches.
  grid_v_.resize((nb + N) * P);
  std::fill_n(grid_v_.data(), nb * P, 0.0);
  double* v = grid_v_.data() + nb * P;
  for (std::size_t k = 1; k < stretches_.size(); ++k)
    std::fill(v + stretches_[k - 1].end * P, v + stretches_[k].begin * P, 0.0);
  const auto uj = u.col(static_cast<Eigen::Index>(j));
  for (const detail::RowSpan& stretch : stretches_)
    for (Eigen::Index t = stretch.begin; t < stretch.end; ++t) {
      const double x = t - stretch.begin >= ch.delay ? uj[t - ch.delay] : 0.0;
      double* vt = v + t * P;
      for (int g = 0; g < P; ++g) vt[g] = x + pole[g] * vt[g - P];
    }
  const int n_products = nb * (nb + 1) / 2;  // rows of grid_sums_: G_g(k, l), l <= k; h_g(k)
  grid_sums_.resize((n_products + nb) * P);
  const double* res = residual_.data();
  for (int k = 0; k < nb; ++k)
    for (int l = 0; l <= k; ++l) {  // one pass: G_g(k, l) and, on the diagonal, h_g(k)
      std::array<double, P> g_kl{}, h_k{};
      const bool diagonal = l == k;
      for (const detail::RowSpan& rows : equations_)
        for (Eigen::Index t = rows.begin; t < rows.end; ++t) {
          const double *vk = v + (t - k) * P, *vl = v + (t - l) * P;
          for (int g = 0; g < P; ++g) g_kl[g] += vk[g] * vl[g];
          if (diagonal)
            for (int g = 0; g < P; ++g) h_k[g] += vk[g] * res[t];
        }
      std::copy(g_kl.begin(), g_kl.end(), grid_sums_.data() + (k * (k + 1) / 2 + l) * P);
      if (diagonal) std::copy(h_k.begin(), h_k.end(), grid_sums_.data() + (n_products + k) * P);
    }

  G_.resize(nb, nb);
  h_.resize(nb);
  double best = INFINITY;
  for (int g = 0; g < P; ++g) {
    const double* acc = grid_sums_.data() + g;
    for (int k = 0; k < nb; ++k)
      for (int l = 0; l <= k; ++l, acc += P) G_(k, l) = G_(l, k) = *acc;
    for (int k = 0; k < nb; ++k, acc += P) h_[k] = *acc;
    ldlt_.compute(G_);
    delta_ = ldlt_.solve(h_);
    const double cost = 0.5 * (rr - h_.dot(delta_));  // LS cost with b_j eliminated
    if (ldlt_.info() == Eigen::Success && delta_.allFinite() && cost < best) {
      best = cost;
      out.b[j] = delta_;
      f1_ << 1.0, -pole[g];
      out.f[j] = f1_;
    }
  }
}

double OutputErrorEstimator::criterion_sum_of_squares(const Eigen::VectorXd& x) const {
  double sum = 0.0;
  for (const detail::RowSpan& rows : equations_)
    sum += x.segment(rows.begin, rows.size()).squaredNorm();
  return sum;
}

double OutputErrorEstimator::simulate(const Eigen::Ref<const Eigen::MatrixXd>& u, const double* y,
                                      Eigen::Index N, const OeResult& par) {
  using ConstSegment = Eigen::Map<const Eigen::VectorXd>;
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    // w_j = q^-d_j / F_j u_j is both the b-sensitivity and, through yhat_j = B_j w_j,
    // the simulation: one recursive filter per channel instead of two. yhat_j is not
    // stored: e = y - sum_jk b_jk w_j(t - k) in one pass per term.
    filter_into(unit_, par.f[j], channels_[j].delay, stretches_, u.col(j), w_[j].segment(pad_, N));
    const double* w = w_[j].data() + pad_;
    for (Eigen::Index k = 0; k < par.b[j].size(); ++k) {
      const ConstSegment w_k(w - k, N);  // pad_ >= nb - 1
      if (j == 0 && k == 0)
        error_ = ConstSegment(y, N) - par.b[j][k] * w_k;
      else
        error_ -= par.b[j][k] * w_k;
    }
  }
  return 0.5 * criterion_sum_of_squares(error_);
}

void OutputErrorEstimator::jacobian_columns(Eigen::Index N, const OeResult& par) {
  // Sensitivities at the parameters simulate() last saw: d yhat/d b_jk = w_j(t - k),
  // d yhat/d f_jk = -v_j(t - k) with v_j = yhat_j / F_j = B_j s_j, s_j = w_j / F_j: one
  // recursion gives s_j, which Newton's second-order term needs too (newton_hessian).
  columns_.resize(static_cast<std::size_t>(p_));
  std::size_t c = 0;
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const OeChannel& ch = channels_[j];
    for (int k = 0; k < ch.nb; ++k) columns_[c++] = {w_[j].data() + pad_, k, 1.0};
    if (ch.nf == 0) continue;
    filter_into(unit_, par.f[j], 0, stretches_, w_[j].segment(pad_, N), s_[j].segment(pad_, N));
    filter_into(par.b[j], unit_, 0, stretches_, s_[j].segment(pad_, N), v_[j].segment(pad_, N));
    for (int i = 1; i <= ch.nf; ++i) columns_[c++] = {v_[j].data() + pad_, i, -1.0};
  }
}

void OutputErrorEstimator::newton_hessian(Eigen::Index N, const OeResult& par) {
  // Newton's Hessian of sum(eps^2)/2: H = J'J - sum_t eps(t) d2yhat(t)/dtheta2, where per
  // channel (zero across channels and between two b's)
  //   d2yhat/db_k df_i = -q^-(k+i) s,  s = w / F = q^-d u / F^2,
  //   d2yhat/df_i df_l = 2 q^-(i+l) r, r = v / F = yhat / F^2,
  // so the second-order term is a few lagged correlations of eps with s and r.
  // Gauss-Newton (J'J alone) converges only linearly on OE: the residual is the noise,
  // not small, and on the paper's SISO windows it contracts the error by ~0.35 per
  // iteration (9 iterations per window on average, up to 17); Newton needs 4.9.
  H_ = G_;
  const auto correlation = [&](const Eigen::VectorXd& x, Eigen::Index lag) {
    double sum = 0.0;
    for (const detail::RowSpan& rows : equations_)
      sum += Eigen::Map<const Eigen::VectorXd>(error_.data() + rows.begin, rows.size())
                 .dot(Eigen::Map<const Eigen::VectorXd>(x.data() + pad_ + rows.begin - lag,
                                                        rows.size()));
    return sum;
  };
  Eigen::Index first = 0;  // index of channel j's b_j0 in theta
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const OeChannel& ch = channels_[j];
    if (ch.nf > 0) {
      filter_into(unit_, par.f[j], 0, stretches_, v_[j].segment(pad_, N), r_[j].segment(pad_, N));
      const Eigen::Index f0 = first + ch.nb - 1;  // theta index of f_ji is f0 + i
      for (int i = 1; i <= ch.nf; ++i) {
        for (int k = 0; k < ch.nb; ++k) {
          H_(first + k, f0 + i) += correlation(s_[j], k + i);
          H_(f0 + i, first + k) = H_(first + k, f0 + i);
        }
        for (int l = 1; l <= i; ++l) {
          H_(f0 + i, f0 + l) -= 2.0 * correlation(r_[j], i + l);
          H_(f0 + l, f0 + i) = H_(f0 + i, f0 + l);
        }
      }
    }
    first += Eigen::Index{ch.nb} + ch.nf;
  }
}

void OutputErrorEstimator::throw_if_not_informative(const detail::NormalEquationsSolver::Outcome& o,
                                                    const char* where) const {
  using Status = detail::NormalEquationsSolver::Status;
  if (o.status == Status::Ok) return;
  throw NumericalError(
      std::string("data not informative for the OE structure: ") + where +
      (o.status == Status::ZeroColumn ? " has a regressor with no energy" : " is rank-deficient"));
}

void OutputErrorEstimator::fir_start(const Eigen::Ref<const Eigen::MatrixXd>& u, const double* y,
                                     OeResult& out) {
  // Joint FIR least squares: channel j gets L_j taps on q^-d_j u_j (nb_j taps if linear).
  columns_.clear();
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const OeChannel& ch = channels_[j];
    for (const detail::RowSpan& s : stretches_) {  // q^-d_j u_j, each stretch from rest
      auto w = w_[j].segment(pad_ + s.begin, s.size());
      const Eigen::Index d = std::min<Eigen::Index>(ch.delay, s.size());
      w.head(d).setZero();
      w.tail(s.size() - d) = u.col(j).segment(s.begin, s.size() - d);
    }
    const int L = init_fir_length(j, n_eq_);
    for (int k = 0; k < L; ++k) columns_.push_back({w_[j].data() + pad_, k, 1.0});
  }
  detail::lagged_normal_equations(columns_, y, equations_, G_, h_);
  throw_if_not_informative(solver_.solve(G_, h_, 0.0, options_.rank_tolerance, theta_),
                           "the FIR start fit");
  Eigen::Index k = 0;
  for (std::size_t j = 0; j < channels_.size(); ++j) {
    const int L = init_fir_length(j, n_eq_);
    prony_start(j, theta_.segment(k, L), out.b[j], out.f[j]);
    k += L;
  }
}

void OutputErrorEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                                    const Eigen::Ref<const Eigen::MatrixXd>& u, Eigen::Index skip,
                                    OeResult& out,
                                    const std::vector<Eigen::VectorXd>* initial_impulse,
                                    const std::vector<Eigen::Index>& stretch_starts) {
  const std::size_t m = channels_.size();
  if (u.cols() != static_cast<Eigen::Index>(m))
    throw InputError("u must have one column per channel (" + std::to_string(m) + "), got " +
                     std::to_string(u.cols()));
  if (u.rows() != y.size())
    throw InputError("u must have as many rows as y has samples (" + std::to_string(y.size()) +
                     "), got " + std::to_string(u.rows()));
  if (skip < 0) throw InputError("skip must be >= 0");
  if (initial_impulse && initial_impulse->size() != m)
    throw InputError("initial_impulse must have one response per channel");
  detail::stretch_spans(y.size(), stretch_starts, record_);
  const auto& record = record_;
  n_eq_ = 0;
  for (const auto& s : record) n_eq_ += std::max<Eigen::Index>(s.size() - skip, 0);
  if (n_eq_ < 2 * p_)
    throw NumericalError("window too short for the OE structure: " + std::to_string(n_eq_) +
                         " equations for " + std::to_string(p_) +
                         " parameters (need >= " + std::to_string(2 * p_) + ")");
  if (check_signals_) require_informative_window(y, u);

  // History the lagged columns may reach before a stretch's first row (zero initial state).
  pad_ = 0;
  for (std::size_t j = 0; j < m; ++j) {
    const int L = (!initial_impulse || channels_[j].nf == 0) ? init_fir_length(j, n_eq_) : 0;
    if (channels_[j].nf > 0 && !initial_impulse && L < channels_[j].nb + channels_[j].nf)
      throw NumericalError("window too short for the OE start fit: " + std::to_string(n_eq_) +
                           " equations");
    // Newton's second-order term reaches lags nb - 1 + nf and 2 nf (newton_hessian).
    pad_ = std::max<Eigen::Index>(
        pad_, std::max({channels_[j].nb - 1 + channels_[j].nf, 2 * channels_[j].nf, L - 1}));
  }
  // Layout: the stretches one after another with pad_ zero rows between, so that a lagged
  // column reaching before a stretch's first row reads the zeros of a start at rest.
  stretches_.clear();
  equations_.clear();
  Eigen::Index at = 0;
  for (const auto& s : record) {
    stretches_.push_back({at, at + s.size()});
    if (s.size() > skip) equations_.push_back({at + skip, at + s.size()});
    at += s.size() + pad_;
  }
  const Eigen::Index N = stretches_.back().end;
  if (record.size() > 1) {
    y_laid_.setZero(N);
    u_laid_.setZero(N, static_cast<Eigen::Index>(m));
    for (std::size_t k = 0; k < record.size(); ++k) {
      y_laid_.segment(stretches_[k].begin, record[k].size()) =
          y.segment(record[k].begin, record[k].size());
      u_laid_.middleRows(stretches_[k].begin, record[k].size()) =
          u.middleRows(record[k].begin, record[k].size());
    }
  }
  const double* yl = record.size() > 1 ? y_laid_.data() : y.data();
  const Eigen::Ref<const Eigen::MatrixXd> ul =
      record.size() > 1 ? Eigen::Ref<const Eigen::MatrixXd>(u_laid_) : u;
  for (std::size_t j = 0; j < m; ++j)
    for (auto* buf : {&w_[j], &v_[j], &s_[j], &r_[j]}) {
      buf->resize(pad_ + N);
      if (record.size() > 1)
        buf->setZero();  // the rows between stretches are never written
      else
        buf->head(pad_).setZero();
    }
  out.b.resize(m);
  out.f.resize(m);
  candidate_.b.resize(m);
  candidate_.f.resize(m);
  out.equations = n_eq_;
  out.iterations = 0;

  if (initial_impulse && !linear()) {
    for (std::size_t j = 0; j < m; ++j) prony_start(j, (*initial_impulse)[j], out.b[j], out.f[j]);
  } else {
    fir_start(ul, yl, out);
  }
  for (std::size_t j = 0; j < m; ++j)
    if (channels_[j].nf == 1) pole_grid_start(j, ul, yl, N, out);

  double cost = simulate(ul, yl, N, out);
  out.converged = linear();  // the FIR least-squares start is then the optimum
  pack(out, theta_);
  double lambda = 1e-3;
  while (!out.converged && out.iterations < options_.max_iterations) {
    ++out.iterations;
    jacobian_columns(N, out);
    detail::lagged_normal_equations(columns_, error_.data(), equations_, G_, h_);
    const double residual_norm = std::sqrt(2.0 * cost);
    bool stationary = true;  // every sensitivity is orthogonal to the residual
    for (Eigen::Index k = 0; k < p_ && stationary; ++k)
      stationary =
          std::abs(h_[k]) <= options_.gradient_tolerance * std::sqrt(G_(k, k)) * residual_norm;
    if (stationary) {
      out.converged = true;
      break;
    }
    // Newton's curvature where it is positive definite (near the minimum), else
    // Gauss-Newton's J'J (always positive semi-definite: a descent direction).
    newton_hessian(N, out);
    ldlt_.compute(H_);
    const bool newton = ldlt_.info() == Eigen::Success && ldlt_.vectorD().minCoeff() > 0.0;
    const Eigen::MatrixXd& curvature = newton ? H_ : G_;
    bool accepted = false;
    while (!accepted) {
      A_ = curvature;
      A_.diagonal() += lambda * G_.diagonal();  // Marquardt's scaling
      ldlt_.compute(A_);
      delta_ = ldlt_.solve(h_);
      candidate_theta_ = theta_ + delta_;
      unpack(candidate_theta_, candidate_);
      for (std::size_t j = 0; j < m; ++j) stabilise(candidate_.f[j]);
      pack(candidate_, candidate_theta_);
      const double candidate_cost = delta_.allFinite() ? simulate(ul, yl, N, candidate_) : INFINITY;
      // A small step only means convergence when it was (nearly) the undamped
      // (Newton or Gauss-Newton) step; a heavily damped step is small because of the damping.
      const bool nearly_undamped = lambda <= 1e-4;
      // Near the minimum the cost is flat to rounding (a 1e-9 parameter error changes it
      // by ~1e-18 relative), so a cost-decrease test alone stalls at ~sqrt(eps):
      // undamped steps that leave the cost equal up to rounding are accepted too.
      const bool flat = nearly_undamped && candidate_cost <= cost * (1.0 + 1e-13);
      if (candidate_cost < cost || flat) {
        accepted = true;
        lambda = std::max(lambda / 10.0, 1e-12);
        const double step = (candidate_theta_ - theta_).cwiseAbs().maxCoeff();
        theta_.swap(candidate_theta_);
        std::swap(out.b, candidate_.b);
        std::swap(out.f, candidate_.f);
        cost = candidate_cost;
        if (nearly_undamped && step <= options_.step_tolerance *
                                           (theta_.cwiseAbs().maxCoeff() + options_.step_tolerance))
          out.converged = true;
      } else if (lambda > 1e12) {
        // No descent direction left at any damping: theta is a (numerical) minimum.
        out.converged = true;
        cost = simulate(ul, yl, N, out);  // restore w_/error_ at theta
        break;
      } else {
        lambda *= 10.0;
      }
    }
  }

  // Covariance sigma^2 (J'J)^-1 at the estimate; J'J also tells whether it is identified.
  jacobian_columns(N, out);
  detail::lagged_normal_equations(columns_, error_.data(), equations_, G_, h_);
  throw_if_not_informative(solver_.solve(G_, h_, 0.0, options_.rank_tolerance, delta_),
                           "the OE Jacobian at the estimate");
  out.theta = theta_;
  out.cost = cost;
  out.noise_variance = 2.0 * cost / static_cast<double>(n_eq_ - p_);
  solver_.covariance_factor(out.covariance);
  out.covariance *= out.noise_variance;
}

OeResult OutputErrorEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                                        const Eigen::Ref<const Eigen::MatrixXd>& u,
                                        Eigen::Index skip,
                                        const std::vector<Eigen::Index>& stretch_starts) {
  OeResult out;
  estimate(y, u, skip, out, nullptr, stretch_starts);
  return out;
}

OeResult oe(const Eigen::Ref<const Eigen::VectorXd>& y, const Eigen::Ref<const Eigen::MatrixXd>& u,
            const std::vector<OeChannel>& channels, Eigen::Index skip, const OeOptions& options,
            const std::vector<Eigen::Index>& stretch_starts) {
  return OutputErrorEstimator(channels, options).estimate(y, u, skip, stretch_starts);
}

}  // namespace mpmpp
