#include "mpmpp/change_scan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

void check_same_length(Eigen::Index a, Eigen::Index b, Eigen::Index c, Eigen::Index d) {
  if (a != b || a != c || a != d)
    throw InputError("r, r_without, psi and weight must have the same length");
}

// With `held` the channel scale is not fitted but held at *held (a dynamics change that keeps
// the model's gain): the statistic is the drop at that scale, drop + 2 theta rp - theta^2 pp;
// theta_se stays the free estimate's, for the caller's test of the held value.
OnsetFit make_fit(Eigen::Index k, double drop, double rp, double pp,
                  std::optional<double> held = std::nullopt) {
  OnsetFit f;
  f.onset = f.onset_first = f.onset_last = k;
  f.statistic = drop;
  f.theta = held.value_or(0.0);
  if (pp <= 0.0) return f;
  if (!held) f.theta = rp / pp;
  f.statistic += held ? 2.0 * f.theta * rp - f.theta * f.theta * pp : rp * rp / pp;
  f.theta_se = 1.0 / std::sqrt(pp);
  return f;
}

// The two-regressor fit of fit_with_level_step: [theta, c] = G^-1 [rp, rq] with
// G = [[pp, pq], [pq, qq]]; a singular G (no samples of the step, or a step the channel's
// response already spans) leaves the one-regressor fit. With `held` theta is held there and
// only c = (rq - theta pq) / qq is fitted.
OnsetFit make_step_fit(Eigen::Index k, double drop, double rp, double pp, double rq, double pq,
                       double qq, std::optional<double> held = std::nullopt) {
  const double det = pp * qq - pq * pq;
  if (!(qq > 0.0) || !(det > 1e-12 * pp * qq)) return make_fit(k, drop, rp, pp, held);
  OnsetFit f;
  f.onset = f.onset_first = f.onset_last = k;
  f.theta = held ? *held : (qq * rp - pq * rq) / det;
  f.step = held ? (rq - f.theta * pq) / qq : (pp * rq - pq * rp) / det;
  f.statistic = drop + 2.0 * f.theta * rp - f.theta * f.theta * pp + 2.0 * f.step * rq -
                2.0 * f.theta * f.step * pq - f.step * f.step * qq;
  f.theta_se = std::sqrt(qq / det);
  return f;
}

// Gram matrix of the lag vector [e(t), e(t-1), ..., e(t-order)] summed over t.
Eigen::MatrixXd lag_gram(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index t) {
  Eigen::VectorXd x(order + 1);
  for (int l = 0; l <= order; ++l) x[l] = e[t - l];
  return x * x.transpose();
}

// Innovation variance of the least-squares AR fit from a lag Gram matrix over n rows.
double ar_variance(const Eigen::MatrixXd& gram, int order, double n) {
  const Eigen::MatrixXd rxx = gram.bottomRightCorner(order, order);
  const Eigen::VectorXd rxy = gram.col(0).tail(order);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(rxx);
  const double rss = gram(0, 0) - rxy.dot(ldlt.solve(rxy));
  return std::max(rss, 1e-300) / n;
}

// Onsets a scan considers, as sample indices: begin, then begin + min_segment,
// begin + min_segment + step, ..., up to N - min_segment.
std::shared_ptr<const std::vector<Eigen::Index>> scan_onsets(Eigen::Index begin, Eigen::Index n,
                                                             Eigen::Index min_segment,
                                                             Eigen::Index step) {
  auto onsets = std::make_shared<std::vector<Eigen::Index>>(1, begin);
  for (Eigen::Index k = begin + min_segment; k + min_segment <= n; k += step) onsets->push_back(k);
  return onsets;
}

// Index of the first nonzero entry of x (its size when none): runs of zeros a block at a time.
Eigen::Index first_nonzero(const Eigen::Ref<const Eigen::VectorXd>& x) {
  constexpr Eigen::Index block = 32;
  const Eigen::Index n = x.size();
  Eigen::Index t = 0;
  for (; t + block <= n; t += block) {
    // +0 and -0 differ only in the sign bit
    std::uint64_t bits = 0;
    for (Eigen::Index i = 0; i < block; ++i) {
      std::uint64_t v;
      std::memcpy(&v, x.data() + t + i, sizeof v);
      bits |= v << 1;
    }
    if (bits != 0) break;
  }
  while (t < n && x[t] == 0.0) ++t;
  return t;
}

}  // namespace

namespace detail {

// Suffix sums over t >= k of the statistic's three terms, kept only at the onsets a scan
// considers, for the weighting `weight` (column 0) and, with a fold assignment, for the even
// and odd folds' samples (columns 1 and 2; column 0 is then their sum).
class GridSums {
 public:
  // every row is set by accumulate (and column 0 of folded sums by sum_folds)
  GridSums(std::shared_ptr<const std::vector<Eigen::Index>> onsets, bool folds)
      : onsets_(std::move(onsets)),
        drop_(rows(), folds ? 3 : 1),
        rp_(rows(), folds ? 3 : 1),
        pp_(rows(), folds ? 3 : 1) {}

  // Sums of a second regressor q (a level step at the onset): r q, psi q and q q, set by
  // set_step for every row and weighting.
  void with_step() {
    rq_.resize(drop_.rows(), drop_.cols());
    pq_.resize(drop_.rows(), drop_.cols());
    qq_.resize(drop_.rows(), drop_.cols());
  }
  bool has_step() const { return rq_.size() > 0; }
  void set_step(Eigen::Index row, int j, double rq, double pq, double qq) {
    rq_(row, j) = rq;
    pq_(row, j) = pq;
    qq_(row, j) = qq;
  }

  Eigen::Index rows() const { return static_cast<Eigen::Index>(onsets_->size()); }

  // Walks t from the last sample down to `stop`, adding weight(t) * terms(t) (terms(t) gives
  // r^2 - r_without^2, r_without psi and psi^2 at t) to the sums of t's fold, and stores them
  // at every grid onset passed; onsets below `stop` get the sums from `stop` on. Without `Drop`
  // the candidate leaves r unchanged (r_without = r) and the drop sums stay 0.
  template <int M, bool Drop = true, class Terms>
  void accumulate(Eigen::Index n, Eigen::Index stop, const double* weight, const double* odd,
                  Terms terms) {
    double d0 = 0.0, x0 = 0.0, p0 = 0.0, d1 = 0.0, x1 = 0.0, p1 = 0.0, d2 = 0.0, x2 = 0.0, p2 = 0.0;
    const auto store = [&](Eigen::Index row) {
      if constexpr (M == 3) {
        set(row, 1, d1, x1, p1);
        set(row, 2, d2, x2, p2);
      } else {
        set(row, 0, d0, x0, p0);
      }
    };
    const std::vector<Eigen::Index>& onsets = *onsets_;
    Eigen::Index row = rows() - 1;
    for (Eigen::Index t = n - 1; t >= stop && row >= 0; --t) {
      double dt, xt, pt;
      terms(t, dt, xt, pt);
      if constexpr (M == 3) {
        // blocks of one fold are long runs, so the branch is well predicted
        if (odd[t] != 0.0) {
          if constexpr (Drop) d2 += weight[t] * dt;
          x2 += weight[t] * xt;
          p2 += weight[t] * pt;
        } else {
          if constexpr (Drop) d1 += weight[t] * dt;
          x1 += weight[t] * xt;
          p1 += weight[t] * pt;
        }
      } else {
        if constexpr (Drop) d0 += weight[t] * dt;
        x0 += weight[t] * xt;
        p0 += weight[t] * pt;
      }
      if (t == onsets[row]) store(row--);
    }
    for (; row >= 0; --row) store(row);
  }

  void set(Eigen::Index row, int j, double drop, double rp, double pp) {
    drop_(row, j) = drop;
    rp_(row, j) = rp;
    pp_(row, j) = pp;
  }
  double drop(Eigen::Index row, int j) const { return drop_(row, j); }
  double rp(Eigen::Index row, int j) const { return rp_(row, j); }
  double pp(Eigen::Index row, int j) const { return pp_(row, j); }

  // With fold columns: the full weighting is the sum of the two folds.
  void sum_folds() {
    for (Eigen::MatrixXd* m : {&drop_, &rp_, &pp_, &rq_, &pq_, &qq_})
      if (m->size() > 0) m->col(0) = m->col(1) + m->col(2);
  }

  // Best onset for weighting j; `row` receives its grid index. With `latest_tie`, of onsets
  // with the same statistic the latest is taken: inside the other fold's block a fold's sums
  // do not move, so it cannot tell where there the change starts, and the held-out drop is
  // then only counted from where the fold saw it (the earliest onset would charge the other
  // fold for a change applied before it happened).
  // An onset after the first grid onset competes with its statistic less `onset_penalty`.
  // With `scores`, each grid onset's statistic as the scan compares it (less the onset penalty
  // after the first) is written there, for onset_set.
  OnsetFit scan(int j, Eigen::Index* row = nullptr, bool latest_tie = false,
                double onset_penalty = 0.0, std::optional<double> held = std::nullopt,
                std::vector<double>* scores = nullptr) const {
    Eigen::Index best_row = 0;
    if (scores) scores->resize(static_cast<std::size_t>(drop_.rows()));
    double best = statistic(0, j, held), s = best - onset_penalty;
    if (scores) (*scores)[0] = best;
    for (Eigen::Index i = 1; i < drop_.rows(); ++i) {
      // a fold's sums stand still through the other fold's blocks: same sums, same statistic
      if (drop_(i, j) != drop_(i - 1, j) || rp_(i, j) != rp_(i - 1, j) ||
          pp_(i, j) != pp_(i - 1, j) ||
          (has_step() && (rq_(i, j) != rq_(i - 1, j) || pq_(i, j) != pq_(i - 1, j) ||
                          qq_(i, j) != qq_(i - 1, j))))
        s = statistic(i, j, held) - onset_penalty;
      if (scores) (*scores)[static_cast<std::size_t>(i)] = s;
      if (s > best || (latest_tie && s == best)) {
        best = s;
        best_row = i;
      }
    }
    if (row) *row = best_row;
    return fit_at(best_row, j, held);
  }

  // Sets fit.onset_first / onset_last from a scan's `scores` and its best row: the grid onsets
  // within kOnsetSetDrop of the best, widened to the grid onset beyond each end (a change
  // between two grid onsets fits between them), within the grid's regular part (not back across
  // its first gap to `begin`).
  void onset_set(OnsetFit& fit, const std::vector<double>& scores, Eigen::Index best_row) const {
    const double floor = scores[static_cast<std::size_t>(best_row)] - kOnsetSetDrop;
    Eigen::Index first = best_row, last = best_row;
    for (Eigen::Index i = 0; i < drop_.rows(); ++i) {
      if (scores[static_cast<std::size_t>(i)] >= floor) {
        first = std::min(first, i);
        last = std::max(last, i);
      }
    }
    if (first > 1) --first;
    if (last + 1 < drop_.rows()) ++last;
    fit.onset_first = (*onsets_)[first];
    fit.onset_last = (*onsets_)[last];
  }

  OnsetFit fit_at(Eigen::Index i, int j, std::optional<double> held = std::nullopt) const {
    if (has_step())
      return make_step_fit((*onsets_)[i], drop_(i, j), rp_(i, j), pp_(i, j), rq_(i, j), pq_(i, j),
                           qq_(i, j), held);
    return make_fit((*onsets_)[i], drop_(i, j), rp_(i, j), pp_(i, j), held);
  }

  // make_fit's statistic without the rest of the fit
  double statistic(Eigen::Index i, int j, std::optional<double> held = std::nullopt) const {
    if (has_step()) return fit_at(i, j, held).statistic;
    const double pp = pp_(i, j), rp = rp_(i, j);
    if (pp <= 0.0) return drop_(i, j);
    return held ? drop_with(j, i, *held) : drop_(i, j) + rp * rp / pp;
  }

  // Drop of the squared error after the grid onset `row` with channel scale theta (and level
  // step c), weighting j: sum w (r^2 - (r_without - theta psi - c q)^2)
  //   = drop + 2 theta rp - theta^2 pp + 2 c rq - 2 theta c pq - c^2 qq.
  double drop_with(int j, Eigen::Index row, double theta, double c = 0.0) const {
    double d = drop_(row, j) + 2.0 * theta * rp_(row, j) - theta * theta * pp_(row, j);
    if (has_step())
      d += 2.0 * c * rq_(row, j) - 2.0 * theta * c * pq_(row, j) - c * c * qq_(row, j);
    return d;
  }

  // The full scan, each fold's scan and each fold's fit scored on the other fold; with `held`
  // the channel scale is held at that value throughout.
  CrossValidatedOnset cross_validated(double onset_penalty = 0.0,
                                      std::optional<double> held = std::nullopt) const {
    CrossValidatedOnset out;
    std::vector<double> scores;
    Eigen::Index best_row = 0;
    out.full = scan(0, &best_row, false, onset_penalty, held, &scores);
    onset_set(out.full, scores, best_row);  // the full scan's only: the folds' are not reported
    for (int k = 0; k < 2; ++k) {
      Eigen::Index row = 0;
      out.fold[k] = scan(1 + k, &row, true, onset_penalty, held);
      out.heldout[k] = drop_with(2 - k, row, out.fold[k].theta, out.fold[k].step);
    }
    return out;
  }

 private:
  std::shared_ptr<const std::vector<Eigen::Index>> onsets_;
  Eigen::MatrixXd drop_, rp_, pp_, rq_, pq_, qq_;
};

}  // namespace detail

namespace {

using detail::GridSums;

// Sums of the unprojected candidate's terms: before the first sample where the candidate
// differs from the nominal model (psi != 0 or r != r_without: a drift that starts late) every
// term is zero and the sums stay put.
template <int M>
GridSums direct_sums(const Eigen::Ref<const Eigen::VectorXd>& r,
                     const Eigen::Ref<const Eigen::VectorXd>& r_without,
                     const Eigen::Ref<const Eigen::VectorXd>& psi,
                     const Eigen::Ref<const Eigen::VectorXd>& weight, const double* odd,
                     Eigen::Index min_segment, Eigen::Index step) {
  const Eigen::Index n = r.size();
  GridSums sums(scan_onsets(0, n, min_segment, step), M == 3);
  Eigen::Index first = 0;
  while (first < n && psi[first] == 0.0 && r[first] == r_without[first]) ++first;
  sums.accumulate<M>(n, first, weight.data(), odd,
                     [&](Eigen::Index t, double& dt, double& xt, double& pt) {
                       dt = r[t] * r[t] - r_without[t] * r_without[t];
                       xt = r_without[t] * psi[t];
                       pt = psi[t] * psi[t];
                     });
  if constexpr (M == 3) sums.sum_folds();
  return sums;
}

// The scan's terms for a candidate projected beside nuisance columns z (N x m, row-major):
// psi(t) = x(t) - z(t)' b and r_without = r + nominal. One nuisance column (the level alone)
// and no nominal channel (r_without = r: a drift, a missing coupling) are the common cases and
// compiled apart.
struct ProjectedTerms {
  const double *x, *r, *nominal, *z, *b;
  Eigen::Index m;

  template <bool OneColumn, bool WithNominal>
  auto compiled() const {
    return [*this](Eigen::Index t, double& dt, double& xt, double& pt) {
      double fitted;
      if constexpr (OneColumn) {
        fitted = z[t] * b[0];
      } else {
        fitted = 0.0;
        for (Eigen::Index j = 0; j < m; ++j) fitted += z[t * m + j] * b[j];
      }
      const double psi = x[t] - fitted;
      if constexpr (WithNominal) {
        const double rw = r[t] + nominal[t];
        dt = r[t] * r[t] - rw * rw;
        xt = rw * psi;
      } else {
        dt = 0.0;
        xt = r[t] * psi;
      }
      pt = psi * psi;
    };
  }
};

}  // namespace

OnsetFit fit_at_onset(const Eigen::Ref<const Eigen::VectorXd>& r,
                      const Eigen::Ref<const Eigen::VectorXd>& r_without,
                      const Eigen::Ref<const Eigen::VectorXd>& psi,
                      const Eigen::Ref<const Eigen::VectorXd>& weight, Eigen::Index onset) {
  check_same_length(r.size(), r_without.size(), psi.size(), weight.size());
  if (onset < 0 || onset >= r.size()) throw InputError("onset must be inside the record");
  double drop = 0.0, rp = 0.0, pp = 0.0;
  for (Eigen::Index t = onset; t < r.size(); ++t) {
    drop += weight[t] * (r[t] * r[t] - r_without[t] * r_without[t]);
    rp += weight[t] * r_without[t] * psi[t];
    pp += weight[t] * psi[t] * psi[t];
  }
  return make_fit(onset, drop, rp, pp);
}

OnsetFit scan_onset(const Eigen::Ref<const Eigen::VectorXd>& r,
                    const Eigen::Ref<const Eigen::VectorXd>& r_without,
                    const Eigen::Ref<const Eigen::VectorXd>& psi,
                    const Eigen::Ref<const Eigen::VectorXd>& weight, Eigen::Index min_segment,
                    Eigen::Index step) {
  check_same_length(r.size(), r_without.size(), psi.size(), weight.size());
  if (min_segment < 1 || step < 1) throw InputError("min_segment and step must be >= 1");
  return direct_sums<1>(r, r_without, psi, weight, nullptr, min_segment, step).scan(0);
}

CrossValidatedOnset scan_onset_cross_validated(const Eigen::Ref<const Eigen::VectorXd>& r,
                                               const Eigen::Ref<const Eigen::VectorXd>& r_without,
                                               const Eigen::Ref<const Eigen::VectorXd>& psi,
                                               const Eigen::Ref<const Eigen::VectorXd>& weight,
                                               const Eigen::Ref<const Eigen::VectorXd>& odd,
                                               Eigen::Index min_segment, Eigen::Index step) {
  check_same_length(r.size(), r_without.size(), psi.size(), weight.size());
  if (odd.size() != r.size()) throw InputError("odd must have the same length as r");
  if (min_segment < 1 || step < 1) throw InputError("min_segment and step must be >= 1");
  const Eigen::VectorXd in_odd = odd;  // contiguous even if the caller passed a strided view
  return direct_sums<3>(r, r_without, psi, weight, in_odd.data(), min_segment, step)
      .cross_validated();
}

ProjectedOnsetScan::ProjectedOnsetScan(const Eigen::Ref<const Eigen::VectorXd>& r,
                                       const Eigen::Ref<const Eigen::VectorXd>& weight,
                                       const Eigen::Ref<const Eigen::VectorXd>& odd,
                                       const Eigen::Ref<const RowMatrixXd>& columns,
                                       const Eigen::Ref<const RowMatrixXd>& solve,
                                       Eigen::Index begin, Eigen::Index min_segment,
                                       Eigen::Index step, double onset_penalty)
    : r_(r),
      weight_(weight),
      odd_(odd),
      columns_(columns),
      solve_(solve),
      begin_(begin),
      onset_penalty_(onset_penalty) {
  const Eigen::Index n = r.size(), m = columns.cols();
  if (weight.size() != n || odd.size() != n || columns.rows() != n)
    throw InputError("r, weight, odd and the nuisance columns must have the same length");
  if (m < 1 || solve.rows() != m || solve.cols() != n)
    throw InputError("the nuisance solve must be (columns) x (samples)");
  if (min_segment < 1 || step < 1) throw InputError("min_segment and step must be >= 1");
  if (begin < 0 || begin >= n) throw InputError("begin must be inside the record");
  if (!(onset_penalty >= 0.0)) throw InputError("onset_penalty must be >= 0");
  onsets_ = scan_onsets(begin, n, min_segment, step);
  const std::vector<Eigen::Index>& onsets = *onsets_;
  const Eigen::Index rows = static_cast<Eigen::Index>(onsets.size());
  // Per fold (even, odd), at every scanned onset k: sum_{t >= k} w r z(t) and
  // sum_{t >= k} w z(t) z(t)' for the nuisance row z(t).
  Eigen::VectorXd rz[2] = {Eigen::VectorXd::Zero(m), Eigen::VectorXd::Zero(m)};
  Eigen::MatrixXd zz[2] = {Eigen::MatrixXd::Zero(m, m), Eigen::MatrixXd::Zero(m, m)};
  for (int f = 0; f < 2; ++f) {
    rz_[f].resize(rows, m);
    zz_[f].resize(rows, m * m);
  }
  Eigen::Index row = rows - 1;
  for (Eigen::Index t = n - 1; t >= begin && row >= 0; --t) {
    const int f = odd[t] != 0.0 ? 1 : 0;
    const auto z = columns.row(t).transpose();
    rz[f] += (weight[t] * r[t]) * z;
    zz[f].noalias() += (weight[t] * z) * z.transpose();
    if (t == onsets[row]) {
      for (int g = 0; g < 2; ++g) {
        rz_[g].row(row) = rz[g].transpose();
        zz_[g].row(row) = Eigen::Map<const Eigen::RowVectorXd>(zz[g].data(), m * m);
      }
      --row;
    }
  }
}

CrossValidatedOnset ProjectedOnsetScan::fit(const Eigen::Ref<const Eigen::VectorXd>& x,
                                            const std::optional<Eigen::VectorXd>& nominal,
                                            const std::optional<Eigen::VectorXd>& weight) const {
  return sums(x, nominal, weight).cross_validated(onset_penalty_);
}

std::pair<CrossValidatedOnset, CrossValidatedOnset> ProjectedOnsetScan::fit_holding_scale(
    const Eigen::Ref<const Eigen::VectorXd>& x, const std::optional<Eigen::VectorXd>& nominal,
    const std::optional<Eigen::VectorXd>& weight, double scale) const {
  if (!std::isfinite(scale)) throw InputError("the held channel scale must be finite");
  const GridSums s = sums(x, nominal, weight);
  return {s.cross_validated(onset_penalty_), s.cross_validated(onset_penalty_, scale)};
}

std::pair<CrossValidatedOnset, CrossValidatedOnset> ProjectedOnsetScan::fit_with_level_step(
    const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& level,
    const std::optional<Eigen::VectorXd>& nominal) const {
  const Eigen::Index n = r_.size(), m = columns_.cols();
  if (x.size() != n || level.size() != n || (nominal && nominal->size() != n))
    throw InputError("x, level and nominal must have the length of r");
  const Eigen::VectorXd b = solve_ * x;
  const std::vector<Eigen::Index>& onsets = *onsets_;
  GridSums sums(onsets_, true);
  sums.with_step();
  // Per fold, suffix sums over t >= k of w times: r^2 - rw^2, rw psi, psi^2 (the channel),
  // rw L, psi L, L^2 (the step before projection) and rw z, psi z, L z (its projection);
  // sigma = S (L 1{t >= k}) is the step's nuisance coefficient, over every fold.
  struct Fold {
    double drop = 0.0, rp = 0.0, pp = 0.0, rl = 0.0, pl = 0.0, ll = 0.0;
    Eigen::VectorXd rwz, pz, lz;
  } fold[2];
  for (Fold& f : fold) f.rwz = f.pz = f.lz = Eigen::VectorXd::Zero(m);
  // sigma at every onset, one row of S at a time (S is row-major: its columns are strided)
  const Eigen::Index rows = static_cast<Eigen::Index>(onsets.size());
  Eigen::MatrixXd sigma_at(rows, m);
  for (Eigen::Index j = 0; j < m; ++j) {
    const double* s = solve_.row(j).data();
    double running = 0.0;
    Eigen::Index row = rows - 1;
    for (Eigen::Index t = n - 1; t >= begin_ && row >= 0; --t) {
      running += s[t] * level[t];
      if (t == onsets[row]) sigma_at(row--, j) = running;
    }
  }
  Eigen::Index row = rows - 1;
  for (Eigen::Index t = n - 1; t >= begin_ && row >= 0; --t) {
    const auto z = columns_.row(t).transpose();
    const double psi = x[t] - z.dot(b), rw = r_[t] + (nominal ? (*nominal)[t] : 0.0);
    const double w = weight_[t], l = level[t];
    Fold& f = fold[odd_[t] != 0.0 ? 1 : 0];
    f.drop += w * (r_[t] * r_[t] - rw * rw);
    f.rp += w * rw * psi;
    f.pp += w * psi * psi;
    f.rl += w * rw * l;
    f.pl += w * psi * l;
    f.ll += w * l * l;
    f.rwz += (w * rw) * z;
    f.pz += (w * psi) * z;
    f.lz += (w * l) * z;
    if (t != onsets[row]) continue;
    const Eigen::VectorXd sigma = sigma_at.row(row).transpose();
    for (int g = 0; g < 2; ++g) {
      const Fold& h = fold[g];
      const auto rz_all = rz_[g].row(0).transpose(), rz_after = rz_[g].row(row).transpose();
      const Eigen::Map<const Eigen::MatrixXd> zz_all(zz_[g].row(0).data(), m, m);
      // q = L 1{t >= k} - z' sigma: after k it pairs with rw and psi; before k (q = -z' sigma)
      // with r, whose sums there are the totals less the suffix
      const double rq = h.rl - h.rwz.dot(sigma) - sigma.dot(rz_all - rz_after);
      const double pq = h.pl - h.pz.dot(sigma);
      const double qq = h.ll - 2.0 * h.lz.dot(sigma) + sigma.dot(zz_all * sigma);
      sums.set(row, 1 + g, h.drop, h.rp, h.pp);
      sums.set_step(row, 1 + g, rq, pq, qq);
    }
    --row;
  }
  sums.sum_folds();
  return {sums.cross_validated(onset_penalty_), sums.cross_validated(onset_penalty_, 1.0)};
}

GridSums ProjectedOnsetScan::sums(const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const std::optional<Eigen::VectorXd>& nominal,
                                  const std::optional<Eigen::VectorXd>& weight) const {
  const Eigen::Index n = r_.size(), m = columns_.cols();
  if (x.size() != n || (nominal && nominal->size() != n) || (weight && weight->size() != n))
    throw InputError("x, nominal and weight must have the length of r");
  // psi = x - Z b with b = S x; x is zero before its first nonzero sample
  const Eigen::Index x_first = first_nonzero(x);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m);
  if (x_first < n)
    b.noalias() = solve_.middleCols(x_first, n - x_first) * x.segment(x_first, n - x_first);
  // Before both x and the nominal channel start, psi = -Z b and r_without = r: the sums there
  // follow from the nuisance's sums. That is cheaper than the samples when the grid is coarser
  // than the nuisance is wide.
  const std::vector<Eigen::Index>& onsets = *onsets_;
  Eigen::Index stop_row = 0;
  if (!nominal && !weight) {
    const Eigen::Index first = std::max(begin_, x_first);
    stop_row = std::upper_bound(onsets.begin(), onsets.end(), first) - onsets.begin() - 1;
    if (stop_row * m * (m + 1) >= (onsets[stop_row] - begin_) * (m + 8)) stop_row = 0;
  }
  GridSums sums(onsets_, true);
  const ProjectedTerms terms{x.data(),        r_.data(), nominal ? nominal->data() : nullptr,
                             columns_.data(), b.data(),  m};
  const Eigen::Index stop = onsets[stop_row];
  const double* w = weight ? weight->data() : weight_.data();
  if (m == 1 && !nominal)
    sums.accumulate<3, false>(n, stop, w, odd_.data(), terms.compiled<true, false>());
  else if (m == 1)
    sums.accumulate<3>(n, stop, w, odd_.data(), terms.compiled<true, true>());
  else if (!nominal)
    sums.accumulate<3, false>(n, stop, w, odd_.data(), terms.compiled<false, false>());
  else
    sums.accumulate<3>(n, stop, w, odd_.data(), terms.compiled<false, true>());
  if (stop_row > 0) {
    const Eigen::MatrixXd bb = b * b.transpose();
    for (int f = 0; f < 2; ++f) {
      const double drop = sums.drop(stop_row, 1 + f), rp = sums.rp(stop_row, 1 + f),
                   pp = sums.pp(stop_row, 1 + f);
      const double* rz_stop = rz_[f].row(stop_row).data();
      const double* zz_stop = zz_[f].row(stop_row).data();
      for (Eigen::Index i = 0; i < stop_row; ++i) {
        const double* rz = rz_[f].row(i).data();
        const double* zz = zz_[f].row(i).data();
        double rp_before = 0.0, pp_before = 0.0;
        for (Eigen::Index j = 0; j < m; ++j) rp_before += b[j] * (rz[j] - rz_stop[j]);
        for (Eigen::Index j = 0; j < m * m; ++j) pp_before += bb.data()[j] * (zz[j] - zz_stop[j]);
        sums.set(i, 1 + f, drop, rp - rp_before, pp + pp_before);
      }
    }
  }
  sums.sum_folds();
  return sums;
}

namespace {

// The lag Gram matrix sum_t [e(t) .. e(t - order)]' [e(t) .. e(t - order)] over the rows t of
// [max(begin, span), end) whose e(t - span) .. e(t) are all present, and their number.
std::pair<Eigen::MatrixXd, Eigen::Index> ar_gram(const Eigen::Ref<const Eigen::VectorXd>& e,
                                                 int order, Eigen::Index begin, Eigen::Index end,
                                                 int span) {
  if (order < 1) throw InputError("AR order must be >= 1");
  span = std::max(span, order);
  begin = std::max<Eigen::Index>(begin, span);
  if (end > e.size() || end - begin <= 2 * order)
    throw InputError("too few samples for an AR(" + std::to_string(order) + ") fit");
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(order + 1, order + 1);
  Eigen::Index rows = 0;
  // missing[t]: missing values among e(0) .. e(t - 1), so a row's count is a difference.
  std::vector<Eigen::Index> missing(static_cast<size_t>(end) + 1, 0);
  for (Eigen::Index t = 0; t < end; ++t) missing[t + 1] = missing[t] + !std::isfinite(e[t]);
  for (Eigen::Index t = begin; t < end; ++t) {
    if (missing[t + 1] != missing[t - span]) continue;
    gram += lag_gram(e, order, t);
    ++rows;
  }
  if (rows <= 2 * order)
    throw InputError("too few samples for an AR(" + std::to_string(order) + ") fit");
  return {gram, rows};
}

// The AR(p) coefficients a (e(t) ~ a' [e(t - 1) .. e(t - p)]) from the top-left block of a
// lag Gram matrix of order >= p: the normal equations of the fit on the Gram's rows.
Eigen::VectorXd ar_coefficients(const Eigen::MatrixXd& gram, int p) {
  return gram.block(1, 1, p, p).ldlt().solve(gram.col(0).segment(1, p));
}

}  // namespace

Eigen::VectorXd fit_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index begin,
                       Eigen::Index end, int span) {
  const Eigen::MatrixXd gram = ar_gram(e, order, begin, end, span).first;
  Eigen::VectorXd poly(order + 1);
  poly[0] = 1.0;
  poly.tail(order) = -ar_coefficients(gram, order);
  return poly;
}

Eigen::VectorXd ar_residual_variances(const Eigen::Ref<const Eigen::VectorXd>& e, int max_order,
                                      Eigen::Index begin, Eigen::Index end) {
  const auto [gram, rows] = ar_gram(e, max_order, begin, end, max_order);
  Eigen::VectorXd s2(max_order + 1);
  s2[0] = gram(0, 0);
  // Residual sum of squares of a least-squares fit: e'e - g'a (normal equations).
  for (int p = 1; p <= max_order; ++p)
    s2[p] = gram(0, 0) - gram.col(0).segment(1, p).dot(ar_coefficients(gram, p));
  return s2 / static_cast<double>(rows);
}

ArSplit split_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index min_segment,
                 Eigen::Index step) {
  if (order < 1) throw InputError("AR order must be >= 1");
  if (min_segment <= 2 * order || step < 1)
    throw InputError("min_segment must exceed 2 * order; step >= 1");
  const Eigen::Index n = e.size();
  ArSplit out;
  if (n - order < 2 * min_segment) return out;
  Eigen::MatrixXd total = Eigen::MatrixXd::Zero(order + 1, order + 1);
  for (Eigen::Index t = order; t < n; ++t) total += lag_gram(e, order, t);
  const double n_all = static_cast<double>(n - order);
  out.variance_all = ar_variance(total, order, n_all);
  // Walk the onset forward, moving rows from "after" into "before".
  Eigen::MatrixXd before = Eigen::MatrixXd::Zero(order + 1, order + 1);
  Eigen::Index t = order;
  for (Eigen::Index k = order + min_segment; k + min_segment <= n; k += step) {
    for (; t < k; ++t) before += lag_gram(e, order, t);
    const double nb = static_cast<double>(k - order), na = static_cast<double>(n - k);
    const double vb = ar_variance(before, order, nb), va = ar_variance(total - before, order, na);
    const double stat = n_all * std::log(out.variance_all) - nb * std::log(vb) - na * std::log(va);
    if (stat > out.statistic) {
      out.statistic = stat;
      out.onset = k;
      out.variance_before = vb;
      out.variance_after = va;
    }
  }
  return out;
}

}  // namespace mpmpp
