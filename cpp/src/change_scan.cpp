#include "mpmpp/change_scan.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

void check_same_length(Eigen::Index a, Eigen::Index b, Eigen::Index c, Eigen::Index d) {
  if (a != b || a != c || a != d)
    throw InputError("r, r_without, psi and weight must have the same length");
}

OnsetFit make_fit(Eigen::Index k, double drop, double rp, double pp) {
  OnsetFit f;
  f.onset = k;
  f.statistic = drop;
  if (pp <= 0.0) return f;
  f.theta = rp / pp;
  f.statistic += rp * rp / pp;
  f.theta_se = 1.0 / std::sqrt(pp);
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

// Suffix sums over t >= k of the statistic's three terms, kept only at the onsets a scan
// considers (k = 0 and k = min_segment, min_segment + step, ..., N - min_segment), for the
// weighting `weight` (column 0) and, with a fold assignment, for the even and odd folds'
// samples (columns 1 and 2; column 0 is then their sum).
class GridSums {
 public:
  GridSums(const Eigen::Ref<const Eigen::VectorXd>& r,
           const Eigen::Ref<const Eigen::VectorXd>& r_without,
           const Eigen::Ref<const Eigen::VectorXd>& psi,
           const Eigen::Ref<const Eigen::VectorXd>& weight, const double* odd,
           Eigen::Index min_segment, Eigen::Index step) {
    const Eigen::Index n = r.size();
    onsets_.push_back(0);
    for (Eigen::Index k = min_segment; k + min_segment <= n; k += step) onsets_.push_back(k);
    const int m = odd ? 3 : 1;
    const Eigen::Index rows = static_cast<Eigen::Index>(onsets_.size());
    drop_.setZero(rows, m);
    rp_.setZero(rows, m);
    pp_.setZero(rows, m);
    if (odd)
      accumulate<3>(r, r_without, psi, weight, odd);
    else
      accumulate<1>(r, r_without, psi, weight, nullptr);
  }

 private:
  template <int M>
  void accumulate(const Eigen::Ref<const Eigen::VectorXd>& r,
                  const Eigen::Ref<const Eigen::VectorXd>& r_without,
                  const Eigen::Ref<const Eigen::VectorXd>& psi,
                  const Eigen::Ref<const Eigen::VectorXd>& weight, const double* odd) {
    const Eigen::Index n = r.size();
    const Eigen::Index rows = static_cast<Eigen::Index>(onsets_.size());
    // Before the first sample where the candidate differs from the nominal model (psi != 0 or
    // r != r_without: a drift that starts late) every term is zero and the sums stay put.
    Eigen::Index first = 0;
    while (first < n && psi[first] == 0.0 && r[first] == r_without[first]) ++first;
    double d0 = 0.0, x0 = 0.0, p0 = 0.0, d1 = 0.0, x1 = 0.0, p1 = 0.0, d2 = 0.0, x2 = 0.0, p2 = 0.0;
    const auto store = [&](Eigen::Index row) {
      if constexpr (M == 3) {
        drop_.row(row) << d1 + d2, d1, d2;
        rp_.row(row) << x1 + x2, x1, x2;
        pp_.row(row) << p1 + p2, p1, p2;
      } else {
        drop_(row, 0) = d0;
        rp_(row, 0) = x0;
        pp_(row, 0) = p0;
      }
    };
    Eigen::Index row = rows - 1;
    for (Eigen::Index t = n - 1; t >= first && row >= 0; --t) {
      const double dt = r[t] * r[t] - r_without[t] * r_without[t];
      const double xt = r_without[t] * psi[t];
      const double pt = psi[t] * psi[t];
      if constexpr (M == 3) {
        // blocks of one fold are long runs, so the branch is well predicted
        if (odd[t] != 0.0) {
          d2 += weight[t] * dt;
          x2 += weight[t] * xt;
          p2 += weight[t] * pt;
        } else {
          d1 += weight[t] * dt;
          x1 += weight[t] * xt;
          p1 += weight[t] * pt;
        }
      } else {
        d0 += weight[t] * dt;
        x0 += weight[t] * xt;
        p0 += weight[t] * pt;
      }
      if (t == onsets_[row]) store(row--);
    }
    for (; row >= 0; --row) store(row);
  }

 public:
  // Best onset for weighting j; `row` receives its grid index. With `latest_tie`, of onsets
  // with the same statistic the latest is taken: inside the other fold's block a fold's sums
  // do not move, so it cannot tell where there the change starts, and the held-out drop is
  // then only counted from where the fold saw it (the earliest onset would charge the other
  // fold for a change applied before it happened).
  OnsetFit scan(int j, Eigen::Index* row = nullptr, bool latest_tie = false) const {
    OnsetFit best = make_fit(0, drop_(0, j), rp_(0, j), pp_(0, j));
    Eigen::Index best_row = 0;
    for (Eigen::Index i = 1; i < drop_.rows(); ++i) {
      const OnsetFit f = make_fit(onsets_[i], drop_(i, j), rp_(i, j), pp_(i, j));
      if (f.statistic > best.statistic || (latest_tie && f.statistic == best.statistic)) {
        best = f;
        best_row = i;
      }
    }
    if (row) *row = best_row;
    return best;
  }

  // Drop of the squared error after the grid onset `row` with channel scale theta, weighting j:
  // sum w (r^2 - (r_without - theta psi)^2) = drop + 2 theta rp - theta^2 pp.
  double drop_with(int j, Eigen::Index row, double theta) const {
    return drop_(row, j) + 2.0 * theta * rp_(row, j) - theta * theta * pp_(row, j);
  }

 private:
  std::vector<Eigen::Index> onsets_;
  Eigen::MatrixXd drop_, rp_, pp_;
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
  return GridSums(r, r_without, psi, weight, nullptr, min_segment, step).scan(0);
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
  const GridSums sums(r, r_without, psi, weight, in_odd.data(), min_segment, step);
  CrossValidatedOnset out;
  out.full = sums.scan(0);
  for (int k = 0; k < 2; ++k) {
    Eigen::Index row = 0;
    out.fold[k] = sums.scan(1 + k, &row, true);
    out.heldout[k] = sums.drop_with(2 - k, row, out.fold[k].theta);
  }
  return out;
}

Eigen::VectorXd fit_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index begin,
                       Eigen::Index end) {
  if (order < 1) throw InputError("AR order must be >= 1");
  begin = std::max<Eigen::Index>(begin, order);
  if (end > e.size() || end - begin <= 2 * order)
    throw InputError("too few samples for an AR(" + std::to_string(order) + ") fit");
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(order + 1, order + 1);
  for (Eigen::Index t = begin; t < end; ++t) gram += lag_gram(e, order, t);
  const Eigen::VectorXd a =
      gram.bottomRightCorner(order, order).ldlt().solve(gram.col(0).tail(order));
  Eigen::VectorXd poly(order + 1);
  poly[0] = 1.0;
  poly.tail(order) = -a;
  return poly;
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

Eigen::VectorXd backlash(const Eigen::Ref<const Eigen::VectorXd>& u, double width) {
  if (!(width >= 0.0) || !std::isfinite(width)) throw InputError("backlash width must be >= 0");
  Eigen::VectorXd out(u.size());
  if (u.size() == 0) return out;
  const double half = 0.5 * width;
  double pos = u[0];
  for (Eigen::Index t = 0; t < u.size(); ++t) {
    if (u[t] > pos + half)
      pos = u[t] - half;
    else if (u[t] < pos - half)
      pos = u[t] + half;
    out[t] = pos;
  }
  return out;
}

Eigen::VectorXd stick_slip(const Eigen::Ref<const Eigen::VectorXd>& u, double band) {
  if (!(band >= 0.0) || !std::isfinite(band)) throw InputError("stick-slip band must be >= 0");
  Eigen::VectorXd out(u.size());
  if (u.size() == 0) return out;
  double pos = u[0];
  for (Eigen::Index t = 0; t < u.size(); ++t) {
    if (std::abs(u[t] - pos) > band) pos = u[t];
    out[t] = pos;
  }
  return out;
}

}  // namespace mpmpp
