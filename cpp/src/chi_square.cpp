#include "mpmpp/chi_square.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

constexpr double kTolerance = 1e-15;
constexpr int kMaxTerms = 10000;

// P(a, x) = x^a e^-x / Gamma(a + 1) * sum_n x^n / ((a + 1) ... (a + n)), for x < a + 1.
double lower_series(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < kMaxTerms && std::abs(term) > std::abs(sum) * kTolerance; ++n) {
    term *= x / (a + n);
    sum += term;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// log Q(a, x), Q = e^-x x^a / Gamma(a) * 1 / (x + 1 - a - 1 (1 - a) / (x + 3 - a - ...)),
// x >= a + 1.
double log_upper_fraction(double a, double x) {
  const double tiny = std::numeric_limits<double>::min() / kTolerance;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int n = 1; n < kMaxTerms; ++n) {
    const double an = -n * (n - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kTolerance) break;
  }
  return -x + a * std::log(x) - std::lgamma(a) + std::log(h);
}

}  // namespace

double chi_square_log_survival(double x, int dof) {
  if (dof < 1)
    throw InputError("chi_square_survival: dof must be >= 1, got " + std::to_string(dof));
  if (std::isnan(x)) return x;
  if (x <= 0) return 0.0;
  const double a = 0.5 * dof, h = 0.5 * x;
  return h < a + 1.0 ? std::log1p(-lower_series(a, h)) : log_upper_fraction(a, h);
}

double chi_square_survival(double x, int dof) { return std::exp(chi_square_log_survival(x, dof)); }

}  // namespace mpmpp
