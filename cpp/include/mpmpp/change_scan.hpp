#pragma once
// Change-point scans behind `diagnose`: where in time does a candidate effect start, and
// where do the residual statistics change. Both are exact two-segment least-squares fits
// evaluated for every onset with running sums (O(N) per candidate instead of O(N^2)).
#include <Eigen/Dense>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "mpmpp/eigen_types.hpp"

namespace mpmpp {

// A candidate effect replaces one channel's contribution from the onset on. With r the
// whitened one-step error of the nominal model, r_without the same error with the channel's
// nominal contribution added back (r_without = r for a channel the model lacks) and psi the
// whitened response of the candidate channel shape, the fit after onset k is
//   r_without(t) = theta psi(t) + w(t),  t >= k,   (nominal model before k)
// with w white of unit variance (the caller whitens all three with the same filter and scale).
// The statistic is the drop of the residual sum of squares against the nominal model,
//   sum_{t>=k} (r^2 - r_without^2) + (sum_{t>=k} r_without psi)^2 / sum_{t>=k} psi^2,
// the likelihood-ratio statistic of the candidate for a fixed onset.
// The onsets a scan cannot tell from its best: those whose statistic lies within this of the
// best one's (the chi-square 95 % point of one parameter; the statistic is twice a
// log-likelihood ratio). A likelihood-ratio set for the onset, reported as its first and last
// grid onsets widened to the grid onset beyond each (the change may lie between two); a change
// the input did not excite for hours fits equally anywhere in that time.
constexpr double kOnsetSetDrop = 3.84;

struct OnsetFit {
  Eigen::Index onset = 0;  // first sample of the changed segment
  double statistic = 0.0;  // drop of the residual sum of squares at that onset
  double theta = 0.0;      // least-squares channel scale after the onset
  double theta_se = 0.0;   // its standard error (unit noise variance)
  double step = 0.0;       // the output's level step at the onset (fit_with_level_step; else 0)
  // the onset set's first and last grid onsets (the full scan of a cross-validated fit; else
  // both onset)
  Eigen::Index onset_first = 0, onset_last = 0;
};

// Best onset among k = 0 and k = min_segment, min_segment + step, ..., N - min_segment.
// Samples where weight == 0 are left out (gaps, filter transients, held-out blocks).
OnsetFit scan_onset(const Eigen::Ref<const Eigen::VectorXd>& r,
                    const Eigen::Ref<const Eigen::VectorXd>& r_without,
                    const Eigen::Ref<const Eigen::VectorXd>& psi,
                    const Eigen::Ref<const Eigen::VectorXd>& weight, Eigen::Index min_segment,
                    Eigen::Index step);

// Two-fold cross-validation of the scan (the held-out test of `diagnose`): sample t is in the
// odd fold where odd(t) != 0, else in the even fold. The onset and theta are chosen on one
// fold's samples and the drop of the squared error
//   sum_{t >= onset_k, t in the other fold} weight (r^2 - (r_without - theta_k psi)^2)
// is measured on the other fold's; `full` is the scan on all samples. Inside the other fold's
// blocks a fold's sums do not move, so its onsets there tie exactly: the latest is taken, and
// the held-out drop is counted only from where the fold saw the change. One pass of suffix sums
// serves the three scans and both held-out drops.
struct CrossValidatedOnset {
  OnsetFit full;
  OnsetFit fold[2];
  double heldout[2] = {0.0, 0.0};  // drop on fold 1 - k with the fit of fold k
};
CrossValidatedOnset scan_onset_cross_validated(const Eigen::Ref<const Eigen::VectorXd>& r,
                                               const Eigen::Ref<const Eigen::VectorXd>& r_without,
                                               const Eigen::Ref<const Eigen::VectorXd>& psi,
                                               const Eigen::Ref<const Eigen::VectorXd>& weight,
                                               const Eigen::Ref<const Eigen::VectorXd>& odd,
                                               Eigen::Index min_segment, Eigen::Index step);
// The cross-validated scan of candidates fitted jointly with nuisance columns Z (N x m: an
// output's level and its step + ramp disturbances, whitened). With S (m x N) the weighted
// least-squares solve of Z, a candidate's whitened response x enters as its part the nuisance
// cannot carry, psi = x - Z (S x) (Frisch-Waugh-Lovell), formed sample by sample inside the
// scan's pass. One object per residual r (already projected) serves every candidate fitted to
// it; the scan covers samples from `begin` on and reports onsets as sample indices. Before a
// candidate that starts late (a drift) psi = -Z S x, and the nuisance's own suffix sums, kept
// at the scanned onsets, give the sums there without visiting the samples.
// `onset_penalty`: an onset after `begin` is taken only when its statistic beats the one at
// `begin` by more than this (in each fold's scan as in the full one): a change present
// from `begin` is the simpler hypothesis, and without the charge a stretch that shows the
// change weakly (no excitation) is cut off by chance, dating an error of the model from the
// start an hour or more into the record.
namespace detail {
class GridSums;
}

class ProjectedOnsetScan {
 public:
  ProjectedOnsetScan(const Eigen::Ref<const Eigen::VectorXd>& r,
                     const Eigen::Ref<const Eigen::VectorXd>& weight,
                     const Eigen::Ref<const Eigen::VectorXd>& odd,
                     const Eigen::Ref<const RowMatrixXd>& columns,
                     const Eigen::Ref<const RowMatrixXd>& solve, Eigen::Index begin,
                     Eigen::Index min_segment, Eigen::Index step, double onset_penalty = 0.0);
  // `nominal`: the projected response of the nominal channel the candidate replaces
  // (r_without = r + nominal; none for a channel the model lacks). `weight`: the candidate's
  // own weighting when its drive is missing in places (default: the scan's).
  CrossValidatedOnset fit(const Eigen::Ref<const Eigen::VectorXd>& x,
                          const std::optional<Eigen::VectorXd>& nominal = std::nullopt,
                          const std::optional<Eigen::VectorXd>& weight = std::nullopt) const;
  // The same fit, and from the same sums the fit with the channel scale theta held at `scale`
  // (one parameter fewer: a new dynamics that keeps the model's gain, scale 1).
  std::pair<CrossValidatedOnset, CrossValidatedOnset> fit_holding_scale(
      const Eigen::Ref<const Eigen::VectorXd>& x, const std::optional<Eigen::VectorXd>& nominal,
      const std::optional<Eigen::VectorXd>& weight, double scale) const;
  // The fit with a second regressor: a level step of the output at the onset, `level` the
  // whitened response of a constant (unprojected), q_k = P (level 1{t >= k}) with P the
  // projection on the nuisance's complement. After onset k the model is
  //   r_without = theta psi + c q_k,   before it r = c q_k,
  // both parts counted (q_k is not zero before k once projected). A gain change about an
  // operating point other than the record's mean moves the output's level by
  // (theta - 1) K (mean - reference) at its onset: with the reference unknown, c is free.
  // OnsetFit::step holds c. The second fit, from the same sums, is the step alone (theta held
  // at 1, the model's channel kept): what the channel's change must beat, since in closed loop
  // G u follows a compensated disturbance and a level step plus a small theta fits its steps
  // and ramps.
  std::pair<CrossValidatedOnset, CrossValidatedOnset> fit_with_level_step(
      const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& level,
      const std::optional<Eigen::VectorXd>& nominal = std::nullopt) const;

 private:
  detail::GridSums sums(const Eigen::Ref<const Eigen::VectorXd>& x,
                        const std::optional<Eigen::VectorXd>& nominal,
                        const std::optional<Eigen::VectorXd>& weight) const;
  Eigen::VectorXd r_, weight_, odd_;
  RowMatrixXd columns_, solve_;
  Eigen::Index begin_;
  double onset_penalty_;
  std::shared_ptr<const std::vector<Eigen::Index>> onsets_;
  RowMatrixXd rz_[2], zz_[2];  // per fold, at each onset: suffix sums of w r z and of w z z'
};

// The same fit at a given onset (no scan).
OnsetFit fit_at_onset(const Eigen::Ref<const Eigen::VectorXd>& r,
                      const Eigen::Ref<const Eigen::VectorXd>& r_without,
                      const Eigen::Ref<const Eigen::VectorXd>& psi,
                      const Eigen::Ref<const Eigen::VectorXd>& weight, Eigen::Index onset);

// Least-squares AR(order) fit e(t) + a1 e(t-1) + ... + an e(t-n) = w(t) on rows
// [begin, end) (lags may reach before begin). Returns the monic polynomial [1, a1, ..., an].
// Rows t whose e(t - span) .. e(t) hold a missing value (NaN: a lost sample, or a stretch's
// start-up) are left out; span (at least order) lets fits of several orders use the same rows.
Eigen::VectorXd fit_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index begin,
                       Eigen::Index end, int span = 0);

// The residual mean square of every AR(p) fit, p = 0 .. max_order, each on the same rows as
// fit_ar(e, p, begin, end, max_order) (element p; element 0 is the mean square of e): one Gram
// matrix for all orders, as an order search (BIC) needs, instead of a fit per order.
Eigen::VectorXd ar_residual_variances(const Eigen::Ref<const Eigen::VectorXd>& e, int max_order,
                                      Eigen::Index begin, Eigen::Index end);

// Two-segment AR split of e: for each candidate onset k (step apart, both segments at least
// min_segment long) the Gaussian log-likelihood gain
//   n log s2(all) - k log s2(before) - (n - k) log s2(after)
// of separate AR(order) models (innovation variance and coefficients) before and after k.
struct ArSplit {
  Eigen::Index onset = 0;
  double statistic = 0.0;        // the log-likelihood gain (0 when no split is possible)
  double variance_before = 0.0;  // AR innovation variances of the two segments
  double variance_after = 0.0;
  double variance_all = 0.0;
};
ArSplit split_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index min_segment,
                 Eigen::Index step);

}  // namespace mpmpp
