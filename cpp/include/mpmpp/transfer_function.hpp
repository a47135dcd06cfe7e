#pragma once
// Discrete transfer function in the backward shift q^-1:
//   G(q) = q^-delay * (b0 + b1 q^-1 + ... + bm q^-m) / (1 + a1 q^-1 + ... + an q^-n)
// The denominator is normalised so that den[0] == 1 on construction.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "mpmpp/detail/row_spans.hpp"

namespace mpmpp {

class TransferFunction {
 public:
  // The unit gain 1 (num = [1], den = [1], delay 0): the white-noise model H = 1.
  TransferFunction();
  TransferFunction(Eigen::VectorXd num, Eigen::VectorXd den, int delay = 0);

  // Zero-order-hold discretisation of K e^{-theta s} / (T s + 1) at sample time Ts.
  // theta = (d + f) Ts with integer d and 0 <= f < 1: the fractional part gives an
  // extra numerator term, G = K q^-d [ (1 - a^(1-f)) q^-1 + (a^(1-f) - a) q^-2 ] / (1 - a q^-1),
  // a = exp(-Ts/T). T == 0 is a pure (fractional) delay; theta < 0 or T < 0 is an InputError.
  static TransferFunction from_foptd(double gain, double time_constant_s, double dead_time_s,
                                     double sample_time_s);

  const Eigen::VectorXd& num() const { return num_; }
  const Eigen::VectorXd& den() const { return den_; }
  int delay() const { return delay_; }

  // y = G x with zero initial state (like scipy.signal.lfilter with the delay prepended).
  Eigen::VectorXd filter(const Eigen::Ref<const Eigen::VectorXd>& x) const;
  // First n samples of the impulse / unit-step response, sample 0 first.
  Eigen::VectorXd impulse(int n) const;
  Eigen::VectorXd step(int n) const;
  // G(1) = sum(num) / sum(den); InputError-free, returns inf for a pole at z = 1.
  double dc_gain() const;
  // Finite non-zero poles / zeros in z. Roots at the origin are left out: in q^-1 form
  // they come only from delays and trailing zero coefficients and never decide stability.
  Eigen::VectorXcd poles() const;
  Eigen::VectorXcd zeros() const;
  bool is_stable() const;         // all poles strictly inside the unit circle
  bool is_minimum_phase() const;  // all zeros strictly inside the unit circle
  bool is_zero() const;           // numerator identically zero

  TransferFunction series(const TransferFunction& other) const;    // G * other
  TransferFunction parallel(const TransferFunction& other) const;  // G + other
  TransferFunction inverse() const;  // 1/G for a delay-free G with num[0] != 0

  bool operator==(const TransferFunction& o) const;

 private:
  Eigen::VectorXd num_, den_;
  int delay_;
};

// For people: "q^-14 (0.063) / (1 - 0.93 q^-1)", coefficients to 6 significant digits.
std::string to_string(const TransferFunction& g);

// out = q^-delay num/den x with zero initial state, den monic (den[0] == 1), written into
// a caller-owned buffer of x's size (x and out must not overlap): the allocation-free
// core of TransferFunction::filter, shared with the identification loops that filter
// thousands of windows.
void filter_into(const Eigen::Ref<const Eigen::VectorXd>& num,
                 const Eigen::Ref<const Eigen::VectorXd>& den, int delay,
                 const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::VectorXd> out);
// The same on each of `spans` of x (a record of stretches laid end to end, detail/row_spans.hpp),
// each from rest; the rows outside the spans are not written.
void filter_into(const Eigen::Ref<const Eigen::VectorXd>& num,
                 const Eigen::Ref<const Eigen::VectorXd>& den, int delay,
                 const std::vector<detail::RowSpan>& spans,
                 const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::VectorXd> out);

// Polynomial product in q^-1 (coefficient convolution).
Eigen::VectorXd poly_multiply(const Eigen::Ref<const Eigen::VectorXd>& a,
                              const Eigen::Ref<const Eigen::VectorXd>& b);
// Roots in z of c0 + c1 z^-1 + ... + cn z^-n (leading zeros of c in q^-1 are ignored).
Eigen::VectorXcd poly_roots(const Eigen::Ref<const Eigen::VectorXd>& c);

}  // namespace mpmpp
