#include "mpmpp/detector_training.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>
#include <string>

#include "mpmpp/error.hpp"
#include "mpmpp/resampling.hpp"
#include "mpmpp/window_pooling.hpp"

namespace mpmpp {
namespace {

// Non-overlapping windows spanned by n consecutive moving windows.
int independent_windows(int n_windows, const DetectorConfig& config) {
  return static_cast<int>(
      std::floor((config.window_s + (n_windows - 1) * config.step_s) / config.window_s));
}

// Uniform integer in [0, bound] without modulo bias: masked draws, rejected above bound.
std::uint64_t bounded(std::mt19937_64& engine, std::uint64_t bound) {
  std::uint64_t mask = bound;
  for (int shift = 1; shift < 64; shift *= 2) mask |= mask >> shift;
  std::uint64_t v;
  do v = engine() & mask;
  while (v > bound);
  return v;
}

std::vector<int> shuffled_order(int n, std::uint64_t seed) {
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::mt19937_64 engine(seed);
  for (int i = n - 1; i > 0; --i)
    std::swap(order[i], order[bounded(engine, static_cast<std::uint64_t>(i))]);
  return order;
}

RowMatrixXd take_rows(const Eigen::Ref<const RowMatrixXd>& X, const std::vector<int>& rows) {
  RowMatrixXd out(static_cast<Eigen::Index>(rows.size()), X.cols());
  for (std::size_t r = 0; r < rows.size(); ++r)
    out.row(static_cast<Eigen::Index>(r)) = X.row(rows[r]);
  return out;
}

// Sample covariance (divisor n - 1) of the rows, any n >= 2.
Eigen::MatrixXd row_covariance(const Eigen::Ref<const RowMatrixXd>& X) {
  const RowMatrixXd centred = X.rowwise() - X.colwise().mean();
  return centred.transpose() * centred / static_cast<double>(X.rows() - 1);
}

OneClassSvmOptions svm_options(const DetectorConfig& config) {
  OneClassSvmOptions o;
  o.nu = config.nu;
  o.kernel_scale = config.kernel_scale;
  return o;
}

std::string format_seconds(double s) {
  std::ostringstream out;
  out << s;
  return out.str();
}

// p of channel k's training against the model (DetectorConfig::model_reference_significance):
// its coefficients pooled over the disjoint training windows ending at the last one, every
// `lag` windows back (the windows a monitored window is pooled with, window_pooling.hpp), and
// Wald-tested against beta = 0. Pooled rather than the plain training mean: in a loop excited
// by a few setpoint steps the windows' precisions differ by orders of magnitude, and the plain
// mean's variance, set by the average window, hides a model error the pooled windows resolve.
// -1 when no training window is usable for the channel.
double training_model_p_value(const WindowFeatures::Series& series, int k,
                              const std::vector<int>& train, int lag) {
  const Eigen::Index d = series.features[k].cols();
  std::vector<Eigen::VectorXd> xs;
  std::vector<Eigen::MatrixXd> cs;
  for (int w = train.back(); w >= 0; w -= lag) {
    if (!std::binary_search(train.begin(), train.end(), w)) continue;
    const Eigen::VectorXd x = series.features[k].row(w).transpose();
    const Eigen::VectorXd c = series.covariances[k].row(w).transpose();
    if (!x.allFinite() || !c.allFinite()) continue;
    xs.push_back(x);
    cs.push_back(Eigen::Map<const RowMatrixXd>(c.data(), d, d));
  }
  if (xs.empty()) return -1.0;
  const PooledEstimate pooled = pool_estimates(xs, cs);
  const double log_p = wald_log_p_value(pooled.mean, pooled.covariance);
  return std::isnan(log_p) ? -1.0 : std::exp(log_p);
}

}  // namespace

double mean_variance_ratio(const std::vector<int>& firsts, int window) {
  if (firsts.empty() || window < 1)
    throw InputError("mean_variance_ratio: needs at least one window of >= 1 sample");
  const auto [lo, hi] = std::minmax_element(firsts.begin(), firsts.end());
  // Coverage count per sample by a difference array: +1 where a window starts, -1 after it.
  std::vector<double> steps(static_cast<std::size_t>(*hi - *lo + window) + 1, 0.0);
  for (int f : firsts) {
    steps[static_cast<std::size_t>(f - *lo)] += 1.0;
    steps[static_cast<std::size_t>(f - *lo + window)] -= 1.0;
  }
  double cover = 0, sum = 0, sum_sq = 0;
  for (std::size_t t = 0; t + 1 < steps.size(); ++t) {
    cover += steps[t];
    sum += cover;
    sum_sq += cover * cover;
  }
  return window * sum_sq / (sum * sum);
}

Eigen::MatrixXd directional_max(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                const Eigen::Ref<const Eigen::MatrixXd>& B) {
  if (A.rows() != A.cols() || B.rows() != A.rows() || B.cols() != A.cols())
    throw InputError("directional_max: A and B must be square matrices of one size");
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> a(A);
  if (a.info() != Eigen::Success || !(a.eigenvalues().minCoeff() > 0))
    throw InputError("the training windows' OE covariance is not positive definite");
  const Eigen::VectorXd sqrt_w = a.eigenvalues().cwiseSqrt();
  const Eigen::MatrixXd root =
      a.eigenvectors() * sqrt_w.asDiagonal() * a.eigenvectors().transpose();
  const Eigen::MatrixXd inv_root =
      a.eigenvectors() * sqrt_w.cwiseInverse().asDiagonal() * a.eigenvectors().transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> b(inv_root * B * inv_root);
  if (b.info() != Eigen::Success) throw InputError("directional_max: eigendecomposition failed");
  const Eigen::VectorXd raised = b.eigenvalues().cwiseMax(1.0);
  const Eigen::MatrixXd V =
      root * b.eigenvectors() * raised.asDiagonal() * b.eigenvectors().transpose() * root;
  return 0.5 * (V + V.transpose());
}

std::uint64_t channel_seed(std::uint64_t seed, int channel) {
  if (channel < 0) throw InputError("channel_seed: channel must be >= 0");
  // NumPy's SeedSequence (pool of 4 32-bit words, entropy = the 32-bit words of seed, then of
  // channel, least significant first, 0 as one word).
  constexpr std::uint32_t kInitA = 0x43b0d7e5, kMultA = 0x931e8875, kInitB = 0x8b51f9dd,
                          kMultB = 0x58f38ded;
  constexpr std::uint32_t kMixL = 0xca01f9dd, kMixR = 0x4973f715;
  constexpr int kPool = 4;
  std::vector<std::uint32_t> entropy;
  auto words = [&](std::uint64_t v) {
    do {
      entropy.push_back(static_cast<std::uint32_t>(v & 0xffffffffu));
      v >>= 32;
    } while (v > 0);
  };
  words(seed);
  words(static_cast<std::uint64_t>(channel));
  std::uint32_t hash_const = kInitA;
  auto hashmix = [&](std::uint32_t value) {
    value ^= hash_const;
    hash_const *= kMultA;
    value *= hash_const;
    return value ^ (value >> 16);
  };
  auto mix = [](std::uint32_t x, std::uint32_t y) {
    const std::uint32_t r = kMixL * x - kMixR * y;
    return r ^ (r >> 16);
  };
  std::uint32_t pool[kPool];
  for (int i = 0; i < kPool; ++i)
    pool[i] = hashmix(i < static_cast<int>(entropy.size()) ? entropy[i] : 0u);
  for (int src = 0; src < kPool; ++src)
    for (int dst = 0; dst < kPool; ++dst)
      if (src != dst) pool[dst] = mix(pool[dst], hashmix(pool[src]));
  for (std::size_t src = kPool; src < entropy.size(); ++src)
    for (int dst = 0; dst < kPool; ++dst) pool[dst] = mix(pool[dst], hashmix(entropy[src]));
  std::uint32_t state[2];
  std::uint32_t out_const = kInitB;
  for (int i = 0; i < 2; ++i) {
    std::uint32_t v = pool[i] ^ out_const;
    out_const *= kMultB;
    v *= out_const;
    state[i] = v ^ (v >> 16);
  }
  // >> 1: the seed stays a non-negative signed 64-bit integer for Python and JSON readers.
  return ((static_cast<std::uint64_t>(state[1]) << 32) | state[0]) >> 1;
}

double outlier_offset(const Eigen::Ref<const Eigen::VectorXd>& scores, double fraction) {
  if (!(fraction > 0 && fraction < 1))
    throw InputError("fraction: must be in (0, 1), got " + std::to_string(fraction));
  const Eigen::Index n = scores.size();
  if (n == 0) throw InputError("scores: empty");
  std::vector<double> s(scores.data(), scores.data() + n);
  std::sort(s.begin(), s.end());
  if (n == 1) return s[0];
  const auto k =
      std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::floor(fraction * n + 0.5)), 1, n - 1);
  return 0.5 * (s[k - 1] + s[k]);
}

OutlierFractionCv cross_validate_outlier_fraction(const Eigen::Ref<const RowMatrixXd>& X,
                                                  const std::vector<double>& fractions, int n_folds,
                                                  std::uint64_t seed,
                                                  const OneClassSvmOptions& svm) {
  if (fractions.empty() ||
      std::any_of(fractions.begin(), fractions.end(), [](double f) { return !(f > 0 && f < 1); }))
    throw InputError("fractions: need a non-empty grid of values in (0, 1)");
  if (n_folds < 2)
    throw InputError("n_folds: must be an integer >= 2, got " + std::to_string(n_folds));
  const int n = static_cast<int>(X.rows());
  if (n < 2 * n_folds)
    throw InputError("X: need at least 2 * n_folds = " + std::to_string(2 * n_folds) +
                     " rows, got " + std::to_string(n));
  OutlierFractionCv cv;
  cv.fractions = Eigen::Map<const Eigen::VectorXd>(fractions.data(),
                                                   static_cast<Eigen::Index>(fractions.size()));
  cv.n_folds = n_folds;
  cv.order = shuffled_order(n, seed);
  Eigen::VectorXd accepted = Eigen::VectorXd::Zero(cv.fractions.size());
  int begin = 0;
  for (int fold = 0; fold < n_folds; ++fold) {
    const int end = begin + n / n_folds + (fold < n % n_folds ? 1 : 0);
    std::vector<int> train(cv.order.begin(), cv.order.begin() + begin);
    train.insert(train.end(), cv.order.begin() + end, cv.order.end());
    const std::vector<int> held(cv.order.begin() + begin, cv.order.begin() + end);
    const RowMatrixXd X_train = take_rows(X, train);
    const OneClassSvmModel model = fit_one_class_svm(X_train, svm);
    const Eigen::VectorXd train_scores = model.score_samples(X_train);
    const Eigen::VectorXd held_scores = model.score_samples(take_rows(X, held));
    for (Eigen::Index k = 0; k < cv.fractions.size(); ++k)
      accepted[k] += static_cast<double>(
          (held_scores.array() - outlier_offset(train_scores, cv.fractions[k]) > 0).count());
    begin = end;
  }
  cv.accuracy = accepted / n;
  Eigen::Index best = 0;
  for (Eigen::Index k = 1; k < cv.fractions.size(); ++k) {
    const double gap = std::abs(cv.accuracy[k] - (1.0 - cv.fractions[k]));
    const double best_gap = std::abs(cv.accuracy[best] - (1.0 - cv.fractions[best]));
    if (gap < best_gap || (gap == best_gap && cv.fractions[k] < cv.fractions[best])) best = k;
  }
  cv.outlier_fraction = cv.fractions[best];
  cv.validation_accuracy = cv.accuracy[best];
  return cv;
}

ResampledModels draw_training_models(const Eigen::Ref<const RowMatrixXd>& estimates,
                                     const DetectorConfig& config, std::uint64_t seed,
                                     const Eigen::Ref<const Eigen::MatrixXd>& reference_covariance,
                                     bool noise) {
  const int n = config.resampled_models;
  const double alpha = noise && config.noise_alpha > 0 ? config.noise_alpha : config.alpha;
  if (reference_covariance.size() != 0) {
    // N(mu, alpha^2 V), V the larger of C_ref and S in every direction. C_ref (the training
    // windows' mean two-step covariance plus their mean's) is computed from every sample, so
    // it is sound even when the training period spans only a few independent windows; S, the
    // sample covariance of the window estimates, takes over where the real spread exceeds it.
    const Eigen::MatrixXd spread =
        directional_max(reference_covariance, coefficient_covariance(estimates));
    return {draw_correlated_gaussian_models(estimates.colwise().mean().transpose(), spread, n,
                                            alpha, seed),
            true};
  }
  // Correlated draws need more independent windows than coefficients: a sample covariance
  // from fewer is singular.
  const bool correlated =
      config.resampling == Resampling::Covariance &&
      independent_windows(static_cast<int>(estimates.rows()), config) > estimates.cols();
  if (correlated) {
    try {
      return {resample(estimates, n, alpha, seed, true), true};
    } catch (const InputError&) {
      // A singular covariance (a coefficient that never varies, collinear estimates): the
      // paper's independent draws, as documented for Resampling::Covariance.
    }
  }
  return {resample(estimates, n, alpha, seed, false), false};
}

ChannelScorer train_channel_scorer(const Eigen::Ref<const RowMatrixXd>& estimates,
                                   const DetectorConfig& config, std::uint64_t seed,
                                   const Eigen::Ref<const Eigen::MatrixXd>& covariances, bool noise,
                                   double mean_ratio) {
  const Eigen::Index d = estimates.cols();
  ChannelScorer s;
  const bool wald =
      noise ? is_wald(config.noise_test) : config.process_test == ProcessTest::Residual;
  if ((config.resampling == Resampling::Estimator || wald) && covariances.size() != 0) {
    if (covariances.rows() != estimates.rows() || covariances.cols() != d * d)
      throw InputError("covariances: need one row of d^2 = " + std::to_string(d * d) +
                       " entries per training window");
    const Eigen::VectorXd mean_row = covariances.colwise().mean().transpose();
    Eigen::MatrixXd window = Eigen::Map<const RowMatrixXd>(mean_row.data(), d, d);
    window = 0.5 * (window + window.transpose()).eval();
    // The frame a window like the training ones maps to itself in: its own covariance plus
    // that of the training mean it is compared with (ChannelScorer::mean_covariance).
    s.mean_covariance = mean_ratio * window;
    s.reference_covariance = window + s.mean_covariance;
  }
  if (wald) {
    // The Wald test needs no cloud: the training mean, its covariance and the level.
    if (covariances.size() == 0)
      throw InputError("a Wald-test channel needs the training windows' covariances");
    s.feature_mean = estimates.colwise().mean().transpose();
    s.feature_scale = Eigen::VectorXd::Ones(d);
    s.significance = noise && config.noise_significance > 0 ? config.noise_significance
                                                            : config.window_significance;
    s.training_windows = static_cast<int>(estimates.rows());
    return s;
  }
  const ResampledModels drawn =
      draw_training_models(estimates, config, seed, s.reference_covariance, noise);
  const RowMatrixXd& Z = drawn.models;
  RowMatrixXd Zs;
  if (config.standardise) {
    // FIR coefficients are ~0.01-0.1, so with the paper's c = 1 the raw kernel
    // exp(-||x - y||^2) is ~1 everywhere and the SVM degenerates to a sphere in the largest
    // coefficients. Centring and scaling each coefficient by the resampled spread, and the
    // vector by 1/sqrt(d), makes ||z - z'||^2 average 2 over the cloud whatever d, so c = 1
    // gives a kernel that is neither flat nor spiky on every channel.
    s.feature_mean = Z.colwise().mean().transpose();
    const RowMatrixXd centred = Z.rowwise() - s.feature_mean.transpose();
    const Eigen::VectorXd population_std =
        (centred.colwise().squaredNorm().transpose() / static_cast<double>(Z.rows())).cwiseSqrt();
    s.feature_scale = population_std * std::sqrt(static_cast<double>(d));
    // A coefficient that never varies (alpha sigma = 0) keeps its raw scale.
    for (Eigen::Index i = 0; i < d; ++i)
      if (!(s.feature_scale[i] > 0)) s.feature_scale[i] = 1.0;
    Zs = centred.array().rowwise() / s.feature_scale.transpose().array();
    if (drawn.correlated) {
      // Whitening: with R the correlation matrix of the resampled models and R = L L',
      // z = L^-1 (x - mean) / (std sqrt(d)) has covariance I / d, so the kernel with c = 1
      // measures Mahalanobis distance: a shift along a precise direction (the gain) counts as
      // much as along a loose one.
      const Eigen::MatrixXd cov = row_covariance(Z);
      const Eigen::VectorXd inv_sd = cov.diagonal().cwiseSqrt().cwiseInverse();
      const Eigen::MatrixXd corr = inv_sd.asDiagonal() * cov * inv_sd.asDiagonal();
      const Eigen::LLT<Eigen::MatrixXd> llt(corr);
      if (llt.info() != Eigen::Success)
        throw InputError("the resampled models' correlation matrix is not positive definite");
      s.feature_decorrelation = llt.matrixL().solve(Eigen::MatrixXd::Identity(d, d));
      Zs = (Zs * s.feature_decorrelation.transpose()).eval();
    }
  } else {
    s.feature_mean = Eigen::VectorXd::Zero(d);
    s.feature_scale = Eigen::VectorXd::Ones(d);
    Zs = Z;
  }
  const OneClassSvmOptions options = svm_options(config);
  double fraction = config.outlier_fraction;
  s.cv_accuracy = -1;
  if (fraction < 0) {
    const OutlierFractionCv cv = cross_validate_outlier_fraction(Zs, config.outlier_fraction_grid,
                                                                 config.cv_folds, seed, options);
    fraction = cv.outlier_fraction;
    s.cv_accuracy = cv.validation_accuracy;
  }
  const OneClassSvmModel svm = fit_one_class_svm(Zs, options);
  s.support_vectors = svm.support_vectors;
  s.dual_coef = svm.dual_coef;
  s.offset = fraction > 0 ? outlier_offset(svm.score_samples(Zs), fraction) : svm.rho;
  s.kernel_scale = config.kernel_scale;
  s.nu = config.nu;
  s.n_train = static_cast<int>(Zs.rows());
  s.training_windows = static_cast<int>(estimates.rows());
  s.outlier_fraction = fraction;
  return s;
}

Detector train_detector(const Model& model, const DetectorConfig& config,
                        const WindowFeatures::Series& series, double train_end_s) {
  config.validate();
  if (!std::isfinite(train_end_s) || train_end_s <= 0)
    throw InputError("train_end_s: must be a positive number of seconds, got " +
                     format_seconds(train_end_s));
  const std::vector<MonitoredChannel> channels = monitored_channels(model, config);
  if (series.features.size() != channels.size())
    throw InputError("train_detector: the series has " + std::to_string(series.features.size()) +
                     " channels, the model " + std::to_string(channels.size()));
  const auto& windows = series.windows;
  const double t0 = windows.empty() ? 0.0 : windows[0].start_s;
  const double train_end_abs =
      t0 + train_end_s + 0.5 * model.sample_time_s;  // as Detector::monitor
  std::vector<int> train, firsts;
  int in_period = 0;
  for (int w = 0; w < static_cast<int>(windows.size()); ++w) {
    if (windows[w].end_s > train_end_abs) continue;
    ++in_period;
    if (windows[w].skipped) continue;
    train.push_back(w);
    firsts.push_back(windows[w].first);
  }
  if (train.size() < 3)
    throw InputError("train_end_s: the training period holds " + std::to_string(train.size()) +
                     " usable windows (" + std::to_string(in_period) + " in all, window " +
                     format_seconds(config.window_s) + " s, step " + format_seconds(config.step_s) +
                     " s); need at least 3 (a window is skipped for a missing value or a time gap "
                     "in it, or a degenerate fit)");
  const double ratio = mean_variance_ratio(firsts, config.window_samples(model.sample_time_s));
  std::vector<ChannelScorer> scorers;
  scorers.reserve(channels.size());
  for (std::size_t k = 0; k < channels.size(); ++k) {
    const RowMatrixXd X = take_rows(series.features[k], train);
    Eigen::MatrixXd covariances;
    if (k < series.covariances.size() && series.covariances[k].cols() > 0) {
      covariances.resize(static_cast<Eigen::Index>(train.size()), series.covariances[k].cols());
      for (std::size_t r = 0; r < train.size(); ++r)
        covariances.row(static_cast<Eigen::Index>(r)) = series.covariances[k].row(train[r]);
    }
    scorers.push_back(
        train_channel_scorer(X, config, channel_seed(config.seed, static_cast<int>(k)), covariances,
                             channels[k].kind == MonitoredChannel::Kind::Noise, ratio));
    ChannelScorer& s = scorers.back();
    if (!channels[k].in_model && config.absent_significance > 0)
      s.significance = config.absent_significance;
    if (config.model_reference_significance > 0 && s.significance > 0 &&
        channels[k].kind == MonitoredChannel::Kind::Process) {
      s.model_p_value = training_model_p_value(series, static_cast<int>(k), train,
                                               config.pooling_lag(model.sample_time_s));
      if (s.model_p_value > config.model_reference_significance)
        s.confirmation = config.training_confirmation;
    }
  }
  return Detector(model, config, train_end_s, std::move(scorers));
}

Detector train_detector(const Model& model, const DetectorConfig& config,
                        const Eigen::Ref<const Eigen::VectorXd>& time_s,
                        const Eigen::Ref<const Eigen::MatrixXd>& u,
                        const Eigen::Ref<const Eigen::MatrixXd>& y, double train_end_s) {
  WindowFeatures features(model, config);
  return train_detector(model, config, features.extract_series(time_s, u, y), train_end_s);
}

}  // namespace mpmpp
