#include "mpmpp/change_scan.hpp"

#include <cmath>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

void check_same_length(Eigen::Index a, Eigen::Index b, Eigen::Index c, Eigen::Index d) {
  if (a != b || a != c || a != d) throw InputError("r, r_without, psi and weight must have the same length");
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

}  // namespace

OnsetFit fit_at_onset(const Eigen::Ref<const Eigen::VectorXd>& r, const Eigen::Ref<const Eigen::VectorXd>& r_without,
                      const Eigen::Ref<const Eigen::VectorXd>& psi, const Eigen::Ref<const Eigen::VectorXd>& weight,
                      Eigen::Index onset) {
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

OnsetFit scan_onset(const Eigen::Ref<const Eigen::VectorXd>& r, const Eigen::Ref<const Eigen::VectorXd>& r_without,
                    const Eigen::Ref<const Eigen::VectorXd>& psi, const Eigen::Ref<const Eigen::VectorXd>& weight,
                    Eigen::Index min_segment, Eigen::Index step) {
  check_same_length(r.size(), r_without.size(), psi.size(), weight.size());
  const Eigen::Index n = r.size();
  if (min_segment < 1 || step < 1) throw InputError("min_segment and step must be >= 1");
  // Suffix sums over t >= k of the three terms of the statistic.
  Eigen::VectorXd sd(n + 1), srp(n + 1), spp(n + 1);
  sd[n] = srp[n] = spp[n] = 0.0;
  for (Eigen::Index t = n - 1; t >= 0; --t) {
    sd[t] = sd[t + 1] + weight[t] * (r[t] * r[t] - r_without[t] * r_without[t]);
    srp[t] = srp[t + 1] + weight[t] * r_without[t] * psi[t];
    spp[t] = spp[t + 1] + weight[t] * psi[t] * psi[t];
  }
  OnsetFit best = make_fit(0, sd[0], srp[0], spp[0]);
  for (Eigen::Index k = min_segment; k + min_segment <= n; k += step) {
    const OnsetFit f = make_fit(k, sd[k], srp[k], spp[k]);
    if (f.statistic > best.statistic) best = f;
  }
  return best;
}

Eigen::VectorXd fit_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index begin,
                       Eigen::Index end) {
  if (order < 1) throw InputError("AR order must be >= 1");
  begin = std::max<Eigen::Index>(begin, order);
  if (end > e.size() || end - begin <= 2 * order)
    throw InputError("too few samples for an AR(" + std::to_string(order) + ") fit");
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(order + 1, order + 1);
  for (Eigen::Index t = begin; t < end; ++t) gram += lag_gram(e, order, t);
  const Eigen::VectorXd a = gram.bottomRightCorner(order, order).ldlt().solve(gram.col(0).tail(order));
  Eigen::VectorXd poly(order + 1);
  poly[0] = 1.0;
  poly.tail(order) = -a;
  return poly;
}

ArSplit split_ar(const Eigen::Ref<const Eigen::VectorXd>& e, int order, Eigen::Index min_segment,
                 Eigen::Index step) {
  if (order < 1) throw InputError("AR order must be >= 1");
  if (min_segment <= 2 * order || step < 1) throw InputError("min_segment must exceed 2 * order; step >= 1");
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
    if (u[t] > pos + half) pos = u[t] - half;
    else if (u[t] < pos - half) pos = u[t] + half;
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
