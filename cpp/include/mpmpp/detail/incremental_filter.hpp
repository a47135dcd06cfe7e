#pragma once
// A transfer function run one sample at a time with its state kept (ring buffers
// of past inputs and outputs), so a closed-loop run costs O(order) per sample and
// never re-filters history. Copying a filter copies its state: the MPC copies the
// nominal model's filters to run the free response forward without disturbing them.
#include <string>
#include <vector>

#include "mpmpp/error.hpp"
#include "mpmpp/transfer_function.hpp"

namespace mpmpp::detail {

class IncrementalFilter {
 public:
  IncrementalFilter() = default;
  explicit IncrementalFilter(const TransferFunction& g)
      : b_(g.num().data(), g.num().data() + g.num().size()),
        a_(g.den().data(), g.den().data() + g.den().size()),
        delay_(g.delay()),
        x_(static_cast<size_t>(g.delay()) + g.num().size(), 0.0),
        y_(g.den().size() > 1 ? g.den().size() - 1 : 1, 0.0) {}

  // Push x(t) and return y(t) = q^-delay B/A x at time t.
  double step(double x) {
    const int nx = static_cast<int>(x_.size()), ny = static_cast<int>(y_.size());
    xh_ = xh_ + 1 == nx ? 0 : xh_ + 1;
    x_[xh_] = x;
    double y = 0.0;
    int idx = xh_ - delay_;
    if (idx < 0) idx += nx;
    for (double b : b_) {
      y += b * x_[idx];
      idx = idx == 0 ? nx - 1 : idx - 1;
    }
    idx = yh_;  // y(t-1)
    for (size_t k = 1; k < a_.size(); ++k) {
      y -= a_[k] * y_[idx];
      idx = idx == 0 ? ny - 1 : idx - 1;
    }
    yh_ = yh_ + 1 == ny ? 0 : yh_ + 1;
    y_[yh_] = y;
    return y;
  }

 private:
  std::vector<double> b_, a_;
  int delay_ = 0;
  std::vector<double> x_{0.0}, y_{0.0};  // ring buffers; x_[xh_] = x(t), y_[yh_] = y(t)
  int xh_ = 0, yh_ = 0;
};

// q G: the same channel seen one sample earlier. A closed loop computes y(t) before
// u(t) exists, so every channel must be strictly proper (delay >= 1 or num[0] == 0,
// as a zero-order-hold discretisation gives); y(t) is then (q G) applied to u(t-1).
inline TransferFunction advanced_one_sample(const TransferFunction& g, const std::string& what) {
  if (g.delay() >= 1) return TransferFunction(g.num(), g.den(), g.delay() - 1);
  if (g.is_zero()) return g;
  if (g.num()[0] != 0.0 || g.num().size() < 2)
    throw InputError(what +
                     " must be strictly proper (delay >= 1 or num[0] == 0): a closed loop "
                     "cannot use u(t) to produce y(t)");
  return TransferFunction(g.num().tail(g.num().size() - 1), g.den(), 0);
}

}  // namespace mpmpp::detail
