#include "mpmpp/residual_regression.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "mpmpp/arx_oe.hpp"
#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

// Singular values below this fraction of the largest (regressors scaled to unit RMS) are
// taken as exact collinearity: the same structural directions in every window.
constexpr double kRankTolerance = 1e-8;

// Alternations of A(q) and beta. Two: run to convergence (6 passes) the joint fit trades
// beta against A(q), its conditional covariance understates beta's spread, and the paper SISO
// noise change raised a false MPM alarm in 18 of 40 runs (seeds 0-39, window level 0.05)
// instead of 7.
constexpr int kPasses = 2;

// The share of a window's samples one input may have lost (hold_lost_inputs). The held values'
// error moves beta: on a tuning-family window (pi_siso seed 1, 1440 samples, the model right)
// by a Mahalanobis distance squared of 0.04 (2 samples lost at random), 0.13 (7), 0.18 (14),
// 0.55 (36) against beta from the complete window, 0.14-0.63 with 2-14 of its largest moves
// lost; the Wald statistics, judged against chi-square(6) quantiles of 17-22, bear those of
// 1 %.
constexpr double kMaxLostInputShare = 0.01;

// The slowest pole's magnitude, the time scale of the channel's response, kept inside
// [0.2, 0.99] so the Laguerre filters neither vanish in one sample nor never settle.
double laguerre_pole(const TransferFunction& g) {
  double p = 0.5;
  if (g.den().size() > 1) p = g.poles().cwiseAbs().maxCoeff();
  return std::clamp(p, 0.2, 0.99);
}

// Samples until the last of n Laguerre filters with pole p has fallen to 1 % (from rest).
int laguerre_settling(double p, int n) {
  return static_cast<int>(std::ceil((n + 1) * std::log(0.01) / std::log(p)));
}

// L_k(q) = sqrt(1 - p^2) q^-1 (q^-1 - p)^k / (1 - p q^-1)^(k+1), k = 0..n-1: orthonormal
// impulse responses on one time scale.
std::vector<TransferFunction> laguerre_filters(double p, int n) {
  const Eigen::VectorXd pole = Eigen::Vector2d(1.0, -p);
  const TransferFunction all_pass(Eigen::Vector2d(-p, 1.0), pole);
  TransferFunction l(Eigen::VectorXd::Constant(1, std::sqrt(1.0 - p * p)), pole, 1);
  std::vector<TransferFunction> filters;
  for (int k = 0; k < n; ++k) {
    filters.push_back(l);
    l = l.series(all_pass);
  }
  return filters;
}

// Least squares b = argmin ||z - Z b|| by a truncated SVD of the column-scaled Z, with the
// covariance sigma^2 (Z'Z)^+ on the same subspace. False when Z has no usable column.
bool truncated_least_squares(const Eigen::MatrixXd& Z, const Eigen::VectorXd& z, Eigen::VectorXd& b,
                             Eigen::MatrixXd* covariance) {
  const Eigen::Index n = Z.rows(), p = Z.cols();
  Eigen::VectorXd scale =
      (Z.colwise().squaredNorm().transpose() / static_cast<double>(n)).cwiseSqrt();
  for (Eigen::Index k = 0; k < p; ++k)
    if (!(scale[k] > 0)) scale[k] = 1.0;
  const Eigen::MatrixXd Zs = Z * scale.cwiseInverse().asDiagonal();
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(Zs, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  if (s.size() == 0 || !(s[0] > 0)) return false;
  Eigen::Index rank = 0;
  while (rank < s.size() && s[rank] > kRankTolerance * s[0]) ++rank;
  const Eigen::MatrixXd V = svd.matrixV().leftCols(rank);
  const Eigen::VectorXd inv_s = s.head(rank).cwiseInverse();
  const Eigen::VectorXd bs =
      V * (inv_s.asDiagonal() * (svd.matrixU().leftCols(rank).transpose() * z));
  b = scale.cwiseInverse().asDiagonal() * bs;
  if (covariance) {
    if (n <= rank) return false;
    const double sigma2 = (z - Zs * bs).squaredNorm() / static_cast<double>(n - rank);
    const Eigen::MatrixXd Vs = V * inv_s.asDiagonal();
    *covariance = scale.cwiseInverse().asDiagonal() * (sigma2 * Vs * Vs.transpose()) *
                  scale.cwiseInverse().asDiagonal();
  }
  return true;
}

// x(t) - sum_k a_k x(t - k) for t = na .. n-1 (A(q) = 1 - a_1 q^-1 - ... applied to a block).
Eigen::MatrixXd whiten(const Eigen::MatrixXd& x, const Eigen::VectorXd& a) {
  const Eigen::Index na = a.size(), m = x.rows() - na;
  Eigen::MatrixXd w = x.bottomRows(m);
  for (Eigen::Index k = 1; k <= na; ++k) w -= a[k - 1] * x.middleRows(na - k, m);
  return w;
}

// The AR fit's regressors for r: rows t = na .. end, the lags r(t-1) .. r(t-na) beside the
// window's trend (level and ramp).
Eigen::MatrixXd lagged_with_trend(const Eigen::VectorXd& r, const Eigen::MatrixXd& trend, int na) {
  const Eigen::Index rows = trend.rows();
  Eigen::MatrixXd R(rows, na + 2);
  for (int k = 1; k <= na; ++k) R.col(k - 1) = r.segment(na - k, rows);
  R.rightCols(2) = trend;
  return R;
}

// A break in the output error's regression at row k: a level shift s_k(t) = 1{t >= k} and a
// hinge h_k(t) = max(0, t - k) together, so that a ramp's start or end and a step are one break
// whatever A(q) makes of them (near 1 it turns a ramp into a level shift; near white it leaves
// it a hinge), and a wrong A(q) cannot be kept because only one of the two shapes was offered.
struct Break {
  Eigen::Index at = -1;
  double score = 0.0;  // T_k = x_k'e (X_k'(I - P_Z)X_k)^-1 X_k'e / sigma^2, chi-square(2)

  Eigen::MatrixXd columns(Eigen::Index n) const {
    const Eigen::ArrayXd t = Eigen::ArrayXd::LinSpaced(n, 0.0, static_cast<double>(n - 1));
    const double k = static_cast<double>(at);
    Eigen::MatrixXd x(n, 2);
    x.col(0) = (t >= k).cast<double>().matrix();
    x.col(1) = (t - k).max(0.0).matrix();
    return x;
  }
};

// The break, k in [edge, n - edge), that best explains the residual e of a fit on Z (e orthogonal
// to Z's columns): X_k'e and Q'X_k (Q an orthonormal basis of Z's columns) are suffix sums of
// e, t e, Q and t Q, and X_k'X_k is closed-form, so the scan costs O(n rank(Z)).
Break best_break(const Eigen::MatrixXd& Z, const Eigen::VectorXd& e, Eigen::Index edge) {
  const Eigen::Index n = Z.rows();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Z);
  const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, qr.rank());
  const double sigma2 = e.squaredNorm() / static_cast<double>(n - qr.rank());
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(Q.cols()), q1 = q0;  // suffix sums of Q, t Q
  double e0 = 0.0, e1 = 0.0;                                      // suffix sums of e, t e
  Break best;
  for (Eigen::Index k = n - 1; k >= edge; --k) {
    const double t = static_cast<double>(k);
    q0 += Q.row(k).transpose();
    q1 += t * Q.row(k).transpose();
    e0 += e[k];
    e1 += t * e[k];
    if (k >= n - edge) continue;
    const double m = static_cast<double>(n - 1 - k);  // h_k = 1, 2, ..., m after row k
    const Eigen::VectorXd qh = q1 - t * q0;
    Eigen::Matrix2d spread;
    spread(0, 0) = m + 1.0 - q0.squaredNorm();
    spread(1, 1) = m * (m + 1.0) * (2.0 * m + 1.0) / 6.0 - qh.squaredNorm();
    spread(0, 1) = spread(1, 0) = m * (m + 1.0) / 2.0 - q0.dot(qh);
    const Eigen::Vector2d xe(e0, e1 - t * e0);
    const Eigen::LDLT<Eigen::Matrix2d> ldlt(spread);
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-9 * spread.trace()))
      continue;  // (nearly) in Z's span already
    const double score = xe.dot(ldlt.solve(xe)) / sigma2;
    if (score > best.score) best = Break{k, score};
  }
  return best;
}

struct Breaks {
  int max;            // breaks kept at most
  Eigen::Index edge;  // none within this many rows of either end
  double threshold;   // the score a break must reach
};

// truncated_least_squares of z on Z, then breaks appended to Z greedily while the best one's
// score passes the threshold (the fit and covariance are those with the breaks).
bool fit_with_breaks(Eigen::MatrixXd& Z, const Eigen::VectorXd& z, const Breaks& breaks,
                     Eigen::VectorXd& coef, Eigen::MatrixXd* covariance) {
  if (!truncated_least_squares(Z, z, coef, covariance)) return false;
  for (int s = 0; s < breaks.max; ++s) {
    const Break b = best_break(Z, z - Z * coef, breaks.edge);
    if (b.at < 0 || b.score < breaks.threshold) break;
    Z.conservativeResize(Eigen::NoChange, Z.cols() + 2);
    Z.rightCols(2) = b.columns(Z.rows());
    if (!truncated_least_squares(Z, z, coef, covariance)) return false;
  }
  return true;
}

// The rows of a window's AR fit (row i reads v(i) .. v(i + na)) among `usable` (those reading
// no missing sample) that read no outlier: v's samples whose innovation in a first AR fit (with
// the trend) exceeds `sigmas` robust sigmas. An outlier also leaves `memory` later samples of a
// prefiltered v (the moving-average root's filter) carrying its tail, so the rows reading those
// go too. All usable rows when more than a tenth would go: heavy tails, not isolated outliers.
std::vector<Eigen::Index> rows_clear_of_outliers(const Eigen::VectorXd& v,
                                                 const Eigen::MatrixXd& trend, int na, int memory,
                                                 double sigmas,
                                                 const std::vector<Eigen::Index>& usable) {
  const Eigen::Index rows = static_cast<Eigen::Index>(usable.size());
  if (!(sigmas > 0)) return usable;
  const Eigen::MatrixXd R = lagged_with_trend(v, trend, na)(usable, Eigen::all);
  const Eigen::VectorXd target = v.tail(trend.rows())(usable);
  Eigen::VectorXd coef;
  if (!truncated_least_squares(R, target, coef, nullptr)) return usable;
  const Eigen::VectorXd e = target - R * coef;
  std::vector<double> dev(e.data(), e.data() + rows);
  const auto mid = dev.begin() + rows / 2;
  std::nth_element(dev.begin(), mid, dev.end());
  const double median = *mid;
  for (auto& d : dev) d = std::abs(d - median);
  std::nth_element(dev.begin(), mid, dev.end());
  const double limit = sigmas * 1.4826 * *mid;
  // An outlier at v's sample t reads in the rows whose window i .. i + na holds it.
  std::vector<bool> out(static_cast<size_t>(trend.rows()), false);
  for (Eigen::Index r = 0; r < rows; ++r) {
    if (!(std::abs(e[r] - median) > limit)) continue;
    const Eigen::Index i = usable[static_cast<size_t>(r)];
    for (Eigen::Index j = i; j <= std::min(trend.rows() - 1, i + na + memory); ++j)
      out[static_cast<size_t>(j)] = true;
  }
  std::vector<Eigen::Index> kept;
  for (const Eigen::Index i : usable)
    if (!out[static_cast<size_t>(i)]) kept.push_back(i);
  const Eigen::Index dropped = rows - static_cast<Eigen::Index>(kept.size());
  if (dropped == 0 || dropped > rows / 10) return usable;
  return kept;
}

// An input sample a historian lost: the input's filters run through the last value present
// (the first one after it, at the window's start). The held value's error, at most one
// controller move, enters v and the directions x_j alike, which is why few may be lost
// (kMaxLostInputShare). Tried first and not kept: the lost move as a nuisance column of the
// output error (G0's pulse response from the sample). It moved beta no less on average, and
// for a sample in the filters' settling part its column, a decaying transient, is nearly
// collinear with the Laguerre directions: a Mahalanobis shift of 37 on a tuning window
// (mpc_siso_1s seed 116) where holding alone moved beta by 0.00. Returns the largest number
// of samples one input lost.
Eigen::Index hold_lost_inputs(Eigen::MatrixXd& u) {
  const Eigen::Index n = u.rows();
  Eigen::Index most = 0;
  for (Eigen::Index e = 0; e < u.cols(); ++e) {
    Eigen::Index first = 0, lost = 0;
    while (first < n && !std::isfinite(u(first, e))) ++first;
    if (first == n) return n;  // an input with no sample at all
    for (Eigen::Index t = 0; t < n; ++t) {
      if (std::isfinite(u(t, e))) continue;
      u(t, e) = t < first ? u(first, e) : u(t - 1, e);
      most = std::max(most, ++lost);
    }
  }
  return most;
}

// Samples until 1 / (1 - c q^-1)'s impulse response c^k falls below 1 % (0 for c = 0).
int moving_average_memory(double c) {
  return c > 0 ? static_cast<int>(std::ceil(std::log(0.01) / std::log(c))) : 0;
}

// x(t) + c x_f(t - 1) down every column, from rest: the block through 1 / (1 - c q^-1).
void through_moving_average_root(Eigen::Ref<Eigen::MatrixXd> x, double c) {
  for (Eigen::Index t = 1; t < x.rows(); ++t) x.row(t) += c * x.row(t - 1);
}

}  // namespace

ResidualRegression::ResidualRegression(const Model& nominal, int output, std::vector<int> inputs,
                                       const DetectorConfig& config)
    : ar_order_(config.whitening_order(output, nominal.num_outputs())),
      ma_root_(config.whitening_root(output, nominal.num_outputs())),
      settle_(0),
      max_steps_(config.residual_steps),
      step_significance_(config.step_significance),
      outlier_sigmas_(config.outlier_sigmas) {
  // The output's own time scale and earliest response, for the channels it lacks.
  double output_pole = 0.0;
  int shortest_delay = std::numeric_limits<int>::max();
  for (int j = 0; j < nominal.num_inputs(); ++j) {
    if (!nominal.acts(output, j)) continue;
    output_pole = std::max(output_pole, laguerre_pole(*nominal.process[output][j]));
    shortest_delay = std::min(shortest_delay, nominal.process[output][j]->delay());
  }
  for (int j : inputs) {
    if (j < 0 || j >= nominal.num_inputs())
      throw InputError("residual regression: output '" + nominal.outputs[output] +
                       "' has no input " + std::to_string(j));
    if (!nominal.acts(output, j)) {
      if (config.absent_channels < 1 || output_pole == 0.0)
        throw InputError("residual regression: output '" + nominal.outputs[output] +
                         "' has no channel from input '" + nominal.inputs[j] + "'");
      // A channel the model lacks: G0 = 0, so no gain or dead-time direction to perturb; the
      // Laguerre filters in the output's slowest time scale, starting where its fastest
      // modelled channel responds (a coupling acting sooner than every modelled channel of
      // its output is taken as rare), span the first-order responses it may gain.
      nominal_.emplace_back();
      std::vector<TransferFunction> dirs;
      for (auto& l : laguerre_filters(output_pole, config.absent_channels))
        dirs.emplace_back(l.num(), l.den(), l.delay() + std::max(shortest_delay, 1) - 1);
      directions_.push_back(std::move(dirs));
      settle_ = std::max(settle_, std::max(shortest_delay, 1) - 1 +
                                      laguerre_settling(output_pole, config.absent_channels));
      continue;
    }
    const TransferFunction& g = *nominal.process[output][j];
    nominal_.push_back(g);
    // Gain, then two dead-time shifts (one sample either way; d + 2 when d - 1 would be lag 0).
    const int other = g.delay() >= 2 ? g.delay() - 1 : g.delay() + 2;
    std::vector<TransferFunction> dirs{g, TransferFunction(g.num(), g.den(), g.delay() + 1),
                                       TransferFunction(g.num(), g.den(), other)};
    // An integrating channel changes inside its integrators (a level's valve gain, a lag of
    // the flow): its Laguerre directions are integrated too, on its stable part's time scale.
    const TransferFunction stable = without_integrators(g);
    const double p = laguerre_pole(stable);
    const bool integrates = stable.den().size() < g.den().size();
    for (auto& l : laguerre_filters(p, config.laguerre_terms))
      dirs.push_back(integrates ? l.series(TransferFunction(stable.den(), g.den())) : std::move(l));
    directions_.push_back(std::move(dirs));
    settle_ = std::max(
        {settle_, mpmpp::settling_samples(g) + 1, laguerre_settling(p, config.laguerre_terms)});
  }
  // The moving-average root's filter starts from rest too.
  settle_ += moving_average_memory(ma_root_);
}

bool ResidualRegression::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                                  const Eigen::Ref<const Eigen::MatrixXd>& u,
                                  std::vector<Eigen::VectorXd>& beta,
                                  std::vector<Eigen::MatrixXd>& covariance, std::string* reason,
                                  Eigen::VectorXd* ar, Eigen::MatrixXd* ar_covariance) const {
  const Eigen::Index n = y.size();
  const int ne = static_cast<int>(nominal_.size());
  if (u.rows() != n || u.cols() != ne)
    throw InputError("residual regression: u must be " + std::to_string(n) + " x " +
                     std::to_string(ne));
  Eigen::Index columns = 0;
  for (const auto& d : directions_) columns += static_cast<Eigen::Index>(d.size());
  // Lost input samples (hold_lost_inputs): at most kMaxLostInputShare of the window's per input.
  Eigen::MatrixXd uh = u;
  if (hold_lost_inputs(uh) >
      static_cast<Eigen::Index>(kMaxLostInputShare * static_cast<double>(n))) {
    if (reason) *reason = "missing values in the window";
    return false;
  }
  // Filters start from rest: the first settle samples only warm them up (at most a third).
  const Eigen::Index skip = std::min<Eigen::Index>(settle_, n / 3), m = n - skip;
  if (m - ar_order_ < 4 * (columns + ar_order_ + 2)) {
    if (reason) *reason = "window too short for the residual regression";
    return false;
  }
  // Output samples a historian lost (NaN in y): v is unknown there, so every row of the AR and
  // whitened fits that reads one is left out, as an outlier's rows are. Nothing is
  // interpolated. A window that would lose more than a tenth of its rows is skipped.
  const Eigen::Array<bool, Eigen::Dynamic, 1> present = y.array().isFinite();
  // Deviations from the window's means: the filters start from rest at the operating point,
  // so their start-up transient is that of the deviations only (and settles within skip).
  const double level = present.select(y.array(), 0.0).sum() / std::max<double>(present.count(), 1);
  Eigen::VectorXd v = present.select(y.array() - level, 0.0);
  Eigen::MatrixXd X(n, columns);
  Eigen::Index c = 0;
  for (int e = 0; e < ne; ++e) {
    const Eigen::VectorXd ue = uh.col(e).array() - uh.col(e).mean();
    if (nominal_[e]) v -= nominal_[e]->filter(ue);
    for (const auto& d : directions_[e]) X.col(c++) = d.filter(ue);
  }
  // A disturbance with a moving-average root c, H = (1 - c q^-1) / A0: v and the directions
  // through 1 / (1 - c q^-1) leave an AR disturbance for A(q). A wandering disturbance (c near
  // 1) needs an AR far longer than a process change may meet (the whitening order, above); c
  // is the training's and the same in every window, so it cannot absorb a change.
  const int memory = moving_average_memory(ma_root_);
  Eigen::Array<bool, Eigen::Dynamic, 1> known = present;
  if (memory > 0) {
    v = present.select(v, 0.0);  // a lost sample adds nothing to the filtered v after it
    through_moving_average_root(v, ma_root_);
    through_moving_average_root(X, ma_root_);
    // A lost output sample (0 in v) stays in the filtered v for `memory` samples.
    for (Eigen::Index t = 0; t < n; ++t)
      if (!present[t])
        known.segment(t, std::min<Eigen::Index>(memory + 1, n - t)).setConstant(false);
  }
  const Eigen::VectorXd vv = v.tail(m);
  const Eigen::MatrixXd XX = X.bottomRows(m);
  const Eigen::Index rows = m - ar_order_;
  // A level and a ramp in both steps: drifting disturbances are not a process change.
  Eigen::MatrixXd trend(rows, 2);
  trend.col(0).setOnes();
  trend.col(1) = Eigen::VectorXd::LinSpaced(rows, 0.0, 1.0);
  std::vector<Eigen::Index> usable;
  const auto vv_present = known.tail(m);
  for (Eigen::Index i = 0; i < rows; ++i)
    if (vv_present.segment(i, ar_order_ + 1).all()) usable.push_back(i);
  if (static_cast<Eigen::Index>(usable.size()) < rows - rows / 10) {
    if (reason) *reason = "missing values in the window";
    return false;
  }
  const std::vector<Eigen::Index> kept =
      rows_clear_of_outliers(vv, trend, ar_order_, memory, outlier_sigmas_, usable);
  const Eigen::Index used = static_cast<Eigen::Index>(kept.size());
  Eigen::VectorXd b = Eigen::VectorXd::Zero(columns), coef;
  Eigen::MatrixXd cov;
  // Breaks are scanned away from the window's ends (5 % of it each side), where one outlier
  // would pass for one; Bonferroni over the positions scanned.
  Breaks breaks{max_steps_, std::max<Eigen::Index>(ar_order_ + 1, used / 20), 0.0};
  // chi-square(2) upper quantile: -2 log p.
  breaks.threshold =
      -2.0 * std::log(step_significance_ /
                      static_cast<double>(std::max<Eigen::Index>(used - 2 * breaks.edge, 1)));
  for (int pass = 0; pass < kPasses; ++pass) {
    // A(q) from what the current beta leaves of v.
    const Eigen::VectorXd r = vv - XX * b;
    Eigen::MatrixXd R = lagged_with_trend(r, trend, ar_order_)(kept, Eigen::all);
    const Eigen::VectorXd target = r.tail(rows)(kept);
    Eigen::MatrixXd acov;
    const bool last = pass == kPasses - 1;
    if (!fit_with_breaks(R, target, breaks, coef, last && ar_covariance ? &acov : nullptr)) {
      if (reason) *reason = "the output error does not vary in the window";
      return false;
    }
    const Eigen::VectorXd a = coef.head(ar_order_);
    if (last && ar) *ar = -a;  // A(q) v = v - sum a_k v(t-k): ar_k = -a_k, the ARX step's signs
    if (last && ar_covariance) *ar_covariance = acov.topLeftCorner(ar_order_, ar_order_);
    Eigen::MatrixXd Z(rows, columns + 2);
    Z.leftCols(columns) = whiten(XX, a);
    Z.rightCols(2) = trend;
    Z = Z(kept, Eigen::all).eval();
    const Eigen::VectorXd z = whiten(vv, a)(kept, 0);
    if (!fit_with_breaks(Z, z, breaks, coef, last ? &cov : nullptr)) {
      if (reason) *reason = "the inputs do not vary in the window";
      return false;
    }
    b = coef.head(columns);
  }
  if (!cov.allFinite()) {
    if (reason) *reason = "the residual regression is singular in the window";
    return false;
  }
  beta.resize(ne);
  covariance.resize(ne);
  c = 0;
  for (int e = 0; e < ne; ++e) {
    const Eigen::Index p = static_cast<Eigen::Index>(directions_[e].size());
    beta[e] = b.segment(c, p);
    covariance[e] = cov.block(c, c, p, p);
    c += p;
  }
  return true;
}

}  // namespace mpmpp
