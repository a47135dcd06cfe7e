#pragma once
// Training of the moving-window detector (paper Sections 4 and 4.2): from the ARX-OE
// estimates of the training windows to a Detector, as libsvm's svm_train builds an svm_model.
//
// Per monitored channel: the few training-window estimates are enlarged into a cloud of
// synthetic models (resampling, Sec. 4.2, DetectorConfig::resampling), the cloud is
// standardised (and whitened when its draws are correlated), the outlier fraction is fixed or
// chosen by cross-validation, and the one-class SVM (eqs. 15-20) is fitted. Every random step
// draws from std::mt19937_64 streams seeded from DetectorConfig::seed, so a training run is
// reproducible in Python and in a plant-side C++ program alike.
#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "mpmpp/detector.hpp"
#include "mpmpp/detector_config.hpp"
#include "mpmpp/eigen_types.hpp"
#include "mpmpp/model.hpp"
#include "mpmpp/one_class_svm.hpp"
#include "mpmpp/window_features.hpp"

namespace mpmpp {

// Trains on the windows of `series` (extracted with WindowFeatures(model, config)) that end
// at or before the first window's start + train_end_s (half a sample of tolerance, as
// Detector::monitor counts them) and are not skipped. InputError naming train_end_s when
// fewer than 3 such windows exist.
Detector train_detector(const Model& model, const DetectorConfig& config,
                        const WindowFeatures::Series& series, double train_end_s);
// The same from raw data: extracts the window features first.
Detector train_detector(const Model& model, const DetectorConfig& config,
                        const Eigen::Ref<const Eigen::VectorXd>& time_s,
                        const Eigen::Ref<const Eigen::MatrixXd>& u,
                        const Eigen::Ref<const Eigen::MatrixXd>& y, double train_end_s);

// The trained scorer of one channel from its training-window estimates (rows). With
// Resampling::Estimator on a process channel, `covariances` holds each window's feature
// covariance (rows of d^2, row-major) and mean_ratio the covariance of their mean relative to
// one window's (mean_variance_ratio); otherwise `covariances` is empty or has 0 columns.
// noise: a noise-model channel (widened by noise_alpha when that is set).
ChannelScorer train_channel_scorer(
    const Eigen::Ref<const RowMatrixXd>& estimates, const DetectorConfig& config,
    std::uint64_t seed, const Eigen::Ref<const Eigen::MatrixXd>& covariances = Eigen::MatrixXd(),
    bool noise = false, double mean_ratio = 0.0);

// The synthetic models of one channel (Sec. 4.2) and whether they were drawn correlated.
// reference_covariance (empty for none): C_ref of Resampling::Estimator; the draws are then
// N(mean, alpha^2 V) with V = directional_max(C_ref, S), S the estimates' sample covariance.
struct ResampledModels {
  RowMatrixXd models;
  bool correlated = false;
};
ResampledModels draw_training_models(const Eigen::Ref<const RowMatrixXd>& estimates,
                                     const DetectorConfig& config, std::uint64_t seed,
                                     const Eigen::Ref<const Eigen::MatrixXd>& reference_covariance,
                                     bool noise);

// Covariance of the mean of window estimates starting at samples `firsts` (each `window`
// samples long), relative to one window's. An estimate is, to first order, the average of its
// samples' contributions, so the mean weights sample t by the number w_t of windows covering
// it: ratio = window sum(w_t^2) / (sum w_t)^2 (1/n for n disjoint windows, 1 for identical
// ones, 0.29 for the 73 windows of 8 h at a 5 min step).
double mean_variance_ratio(const std::vector<int>& firsts, int window);

// A^1/2 max(I, A^-1/2 B A^-1/2) A^1/2, the max taken on eigenvalues (A positive definite): in
// the coordinates where A is the identity, B's eigenvalues below 1 are raised to 1, so the
// result is at least A and at least B in the Loewner order.
Eigen::MatrixXd directional_max(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                const Eigen::Ref<const Eigen::MatrixXd>& B);

// The seed of channel k's random streams: NumPy's SeedSequence([seed, channel]) hash (its
// first 64-bit word, shifted right by one), so the streams of different channels are
// independent and a Python user can derive them with numpy.random.SeedSequence.
std::uint64_t channel_seed(std::uint64_t seed, int channel);

// Offset that makes `fraction` (in (0, 1)) of `scores` fall below it: with the n scores sorted
// s_1 <= ... <= s_n, k = round(fraction n) clipped to [1, n - 1] (a positive fraction flags at
// least one point and never all) and the offset is (s_k + s_k+1) / 2 (MATLAB fitcsvm's
// OutlierFraction, applied after training). With one score the offset is that score.
double outlier_offset(const Eigen::Ref<const Eigen::VectorXd>& scores, double fraction);

// K-fold cross-validation of the outlier fraction on normal data. The rows are shuffled
// (Fisher-Yates on std::mt19937_64(seed)) and cut into n_folds near-equal folds (the first
// n mod n_folds one row longer). Per fold an SVM is fitted on the other folds (in shuffled
// order); the fit does not depend on the outlier fraction, so each grid value only moves the
// offset (outlier_offset on the training scores). Accuracy of a fraction f: the share of
// held-out rows scored above the offset, pooled over folds. All rows are normal, so the ideal
// is 1 - f; the chosen fraction is the one closest to it (ties to the smaller f): smaller
// values over-fit (held-out rows fall outside a tight boundary), larger ones reject more
// normal windows than needed.
struct OutlierFractionCv {
  Eigen::VectorXd fractions;    // the grid
  Eigen::VectorXd accuracy;     // per grid value
  double outlier_fraction = 0;  // the chosen value
  double validation_accuracy = 0;
  int n_folds = 0;
  std::vector<int> order;  // the shuffled row order the folds were cut from
};
OutlierFractionCv cross_validate_outlier_fraction(const Eigen::Ref<const RowMatrixXd>& X,
                                                  const std::vector<double>& fractions, int n_folds,
                                                  std::uint64_t seed,
                                                  const OneClassSvmOptions& svm);

}  // namespace mpmpp
