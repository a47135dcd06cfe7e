#include "mpmpp/transfer_function.hpp"

#include <cmath>
#include <cstdio>
#include <string>

#include "mpmpp/error.hpp"
#include "order_limits.hpp"

namespace mpmpp {

namespace {

// Drop zero coefficients at the front and back; what remains has the same roots
// in z apart from the origin, which for a q^-1 polynomial is only a pure delay.
Eigen::VectorXd trim_zeros(const Eigen::Ref<const Eigen::VectorXd>& c) {
  Eigen::Index first = 0, last = c.size() - 1;
  while (first <= last && c[first] == 0.0) ++first;
  while (last >= first && c[last] == 0.0) --last;
  if (first > last) return Eigen::VectorXd();
  return c.segment(first, last - first + 1);
}

// c0 + c1 q^-1 + ... with zero terms left out, e.g. "1 - 0.93 q^-1".
std::string polynomial_string(const Eigen::VectorXd& c) {
  std::string out;
  char buf[32];
  for (Eigen::Index k = 0; k < c.size(); ++k) {
    if (c[k] == 0.0) continue;
    const double magnitude = out.empty() ? c[k] : std::abs(c[k]);
    std::snprintf(buf, sizeof buf, "%.6g", magnitude);
    if (!out.empty()) out += c[k] < 0 ? " - " : " + ";
    out += buf;
    if (k > 0) out += " q^-" + std::to_string(k);
  }
  return out.empty() ? "0" : out;
}

bool all_inside_unit_circle(const Eigen::VectorXcd& roots) {
  for (Eigen::Index i = 0; i < roots.size(); ++i)
    if (std::abs(roots[i]) >= 1.0) return false;
  return true;
}

}  // namespace

Eigen::VectorXd poly_multiply(const Eigen::Ref<const Eigen::VectorXd>& a,
                              const Eigen::Ref<const Eigen::VectorXd>& b) {
  if (a.size() == 0 || b.size() == 0) return Eigen::VectorXd();
  Eigen::VectorXd c = Eigen::VectorXd::Zero(a.size() + b.size() - 1);
  for (Eigen::Index i = 0; i < a.size(); ++i) c.segment(i, b.size()) += a[i] * b;
  return c;
}

Eigen::VectorXcd poly_roots(const Eigen::Ref<const Eigen::VectorXd>& c) {
  const Eigen::VectorXd p = trim_zeros(c);
  const Eigen::Index n = p.size() - 1;
  if (n <= 0) return Eigen::VectorXcd();
  // Companion matrix of z^n + (p1/p0) z^(n-1) + ... + pn/p0.
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  companion.row(0) = -p.tail(n).transpose() / p[0];
  if (n > 1) companion.bottomLeftCorner(n - 1, n - 1).setIdentity();
  return companion.eigenvalues();
}

TransferFunction::TransferFunction()
    : num_(Eigen::VectorXd::Ones(1)), den_(Eigen::VectorXd::Ones(1)), delay_(0) {}

TransferFunction::TransferFunction(Eigen::VectorXd num, Eigen::VectorXd den, int delay)
    : num_(std::move(num)), den_(std::move(den)), delay_(delay) {
  if (num_.size() == 0) throw InputError("num must have at least one coefficient");
  if (den_.size() == 0) throw InputError("den must have at least one coefficient");
  if (!num_.allFinite()) throw InputError("num has a non-finite coefficient");
  if (!den_.allFinite()) throw InputError("den has a non-finite coefficient");
  if (den_[0] == 0.0) throw InputError("den[0] must be non-zero");
  if (delay_ < 0) throw InputError("delay must be >= 0, got " + std::to_string(delay_));
  if (delay_ > detail::kMaxLag)
    throw InputError("delay must be <= 1000000 samples, got " + std::to_string(delay_));
  num_ /= den_[0];
  den_ /= den_[0];
}

TransferFunction TransferFunction::from_foptd(double gain, double time_constant_s,
                                              double dead_time_s, double sample_time_s) {
  if (!(sample_time_s > 0.0) || !std::isfinite(sample_time_s))
    throw InputError("sample_time_s must be > 0");
  if (!std::isfinite(gain)) throw InputError("gain must be finite");
  if (!(time_constant_s >= 0.0) || !std::isfinite(time_constant_s))
    throw InputError("time_constant_s must be >= 0");
  if (!(dead_time_s >= 0.0) || !std::isfinite(dead_time_s))
    throw InputError("dead_time_s must be >= 0");
  const double samples = dead_time_s / sample_time_s;
  if (samples > 1e6) throw InputError("dead_time_s must be at most 1e6 samples");
  // Snap to an integer when the dead time is a multiple of Ts up to rounding.
  double whole = std::floor(samples + 1e-9);
  double frac = samples - whole;
  if (frac < 1e-9) frac = 0.0;
  const int d = static_cast<int>(whole);
  if (time_constant_s == 0.0) {
    if (frac == 0.0)
      return TransferFunction(Eigen::VectorXd::Constant(1, gain), Eigen::VectorXd::Ones(1), d);
    return TransferFunction(Eigen::VectorXd::Constant(1, gain), Eigen::VectorXd::Ones(1), d + 1);
  }
  const double a = std::exp(-sample_time_s / time_constant_s);
  Eigen::VectorXd den(2);
  den << 1.0, -a;
  if (frac == 0.0)
    return TransferFunction(Eigen::VectorXd::Constant(1, gain * (1.0 - a)), den, d + 1);
  // Modified z-transform of the ZOH step response with fractional delay f Ts.
  const double af = std::pow(a, 1.0 - frac);
  Eigen::VectorXd num(2);
  num << gain * (1.0 - af), gain * (af - a);
  return TransferFunction(num, den, d + 1);
}

namespace {
// y[t] = c[t] - a1 y[t-1] with c[t] = b0 x[t] (zero initial state), four samples per
// step: given p = y[t-1],
//   y[t+k] = d_k + (-a1)^(k+1) p,  d_0 = c[t],  d_k = c[t+k] - a1 d_(k-1),
// so the loop-carried dependency is one multiply-add per four samples instead of one
// per sample (the d_k of the next block overlap with it). Same result up to rounding.
// The one-tap numerator b0 is applied on the fly: no separate pass writing c.
template <bool kUnitGain>  // b0 == 1: the OE sensitivity filters; skips a multiply per sample
void first_order_recursion(double b0, double a1, const double* x, double* y, Eigen::Index n) {
  const auto c = [b0, x](Eigen::Index t) { return kUnitGain ? x[t] : b0 * x[t]; };
  const double m1 = -a1, m2 = m1 * m1, m3 = m2 * m1, m4 = m2 * m2;
  double p = 0.0;
  Eigen::Index t = 0;
  for (; t + 4 <= n; t += 4) {
    const double d0 = c(t);
    const double d1 = c(t + 1) - a1 * d0;
    const double d2 = c(t + 2) - a1 * d1;
    const double d3 = c(t + 3) - a1 * d2;
    y[t] = d0 + m1 * p;
    y[t + 1] = d1 + m2 * p;
    y[t + 2] = d2 + m3 * p;
    y[t + 3] = d3 + m4 * p;
    p = y[t + 3];
  }
  for (; t < n; ++t) p = y[t] = c(t) - a1 * p;
}
}  // namespace

void filter_into(const Eigen::Ref<const Eigen::VectorXd>& num,
                 const Eigen::Ref<const Eigen::VectorXd>& den, int delay,
                 const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::VectorXd> out) {
  const Eigen::Index n = x.size();
  if (out.size() != n) throw InputError("filter output must have the input's length");
  // The identification's hot path (thousands of windows, several filters per
  // Gauss-Newton iteration): the numerator as shifted vector updates (vectorised), then
  // 1/den as an in-place recursion (c[t] is read before y[t] is written).
  // The first term is assigned, not added to zeros: one pass fewer, same values.
  const Eigen::Index d = std::min<Eigen::Index>(delay, n);
  out.head(d).setZero();
  if (num.size() == 1 && den.size() == 2) {  // b0 q^-d / (1 + a1 q^-1): one fused pass
    if (num[0] == 1.0)
      first_order_recursion<true>(1.0, den[1], x.data(), out.data() + d, n - d);
    else
      first_order_recursion<false>(num[0], den[1], x.data(), out.data() + d, n - d);
    return;
  }
  if (num.size() == 0)
    out.tail(n - d).setZero();
  else
    out.tail(n - d) = num[0] * x.head(n - d);
  for (Eigen::Index k = 1; k < num.size(); ++k) {
    const Eigen::Index shift = delay + k;
    if (shift >= n) break;
    out.tail(n - shift) += num[k] * x.head(n - shift);
  }
  const Eigen::Index na = den.size();
  if (na == 1) return;  // FIR: no recursion
  double* y = out.data();
  if (na == 2) {
    first_order_recursion<true>(1.0, den[1], y, y,
                                n);  // in place: c[t] is read before y[t] is written
    return;
  }
  const double* a = den.data();
  for (Eigen::Index t = 1; t < n; ++t) {
    double acc = y[t];
    for (Eigen::Index k = 1; k < na && k <= t; ++k) acc -= a[k] * y[t - k];
    y[t] = acc;
  }
}

void filter_into(const Eigen::Ref<const Eigen::VectorXd>& num,
                 const Eigen::Ref<const Eigen::VectorXd>& den, int delay,
                 const std::vector<detail::RowSpan>& spans,
                 const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::VectorXd> out) {
  for (const detail::RowSpan& s : spans)
    filter_into(num, den, delay, x.segment(s.begin, s.size()), out.segment(s.begin, s.size()));
}

Eigen::VectorXd TransferFunction::filter(const Eigen::Ref<const Eigen::VectorXd>& x) const {
  Eigen::VectorXd y(x.size());
  filter_into(num_, den_, delay_, x, y);
  return y;
}

Eigen::VectorXd TransferFunction::impulse(int n) const {
  if (n < 0) throw InputError("response length must be >= 0");
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n);
  if (n > 0) u[0] = 1.0;
  return filter(u);
}

Eigen::VectorXd TransferFunction::step(int n) const {
  if (n < 0) throw InputError("response length must be >= 0");
  return filter(Eigen::VectorXd::Ones(n));
}

double TransferFunction::dc_gain() const {
  const double d = den_.sum();
  const double b = num_.sum();
  if (d == 0.0) return b == 0.0 ? 0.0 : std::copysign(INFINITY, b);
  return b / d;
}

Eigen::VectorXcd TransferFunction::poles() const { return poly_roots(den_); }
Eigen::VectorXcd TransferFunction::zeros() const { return poly_roots(num_); }
bool TransferFunction::is_stable() const { return all_inside_unit_circle(poles()); }
bool TransferFunction::is_minimum_phase() const { return all_inside_unit_circle(zeros()); }
bool TransferFunction::is_zero() const { return (num_.array() == 0.0).all(); }

TransferFunction TransferFunction::series(const TransferFunction& o) const {
  const long long delay = static_cast<long long>(delay_) + o.delay_;  // <= 2 kMaxLag: no overflow
  if (delay > detail::kMaxLag)
    throw InputError("series delay must be <= 1000000 samples, got " + std::to_string(delay));
  return TransferFunction(poly_multiply(num_, o.num_), poly_multiply(den_, o.den_),
                          static_cast<int>(delay));
}

TransferFunction TransferFunction::parallel(const TransferFunction& o) const {
  // q^-d1 n1/d1 + q^-d2 n2/d2 = q^-min(d1,d2) (q^-(d1-m) n1 d2 + q^-(d2-m) n2 d1) / (d1 d2).
  // Common factors are not cancelled: the sum keeps both denominators.
  const int m = std::min(delay_, o.delay_);
  const Eigen::VectorXd t1 = poly_multiply(num_, o.den_), t2 = poly_multiply(o.num_, den_);
  const Eigen::Index s1 = delay_ - m, s2 = o.delay_ - m;
  Eigen::VectorXd num = Eigen::VectorXd::Zero(std::max(s1 + t1.size(), s2 + t2.size()));
  num.segment(s1, t1.size()) += t1;
  num.segment(s2, t2.size()) += t2;
  return TransferFunction(num, poly_multiply(den_, o.den_), m);
}

TransferFunction TransferFunction::inverse() const {
  if (delay_ != 0) throw InputError("cannot invert a transfer function with a delay");
  if (num_[0] == 0.0) throw InputError("cannot invert: num[0] is zero (non-causal inverse)");
  return TransferFunction(den_, num_, 0);
}

bool TransferFunction::operator==(const TransferFunction& o) const {
  return delay_ == o.delay_ && num_.size() == o.num_.size() && den_.size() == o.den_.size() &&
         num_ == o.num_ && den_ == o.den_;
}

std::string to_string(const TransferFunction& g) {
  std::string out = g.delay() > 0 ? "q^-" + std::to_string(g.delay()) + " " : "";
  out += "(" + polynomial_string(g.num()) + ")";
  if (g.den().size() > 1) out += " / (" + polynomial_string(g.den()) + ")";
  return out;
}

}  // namespace mpmpp
