#include "mpmpp/mismatch_indicator.hpp"

#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

MismatchIndicator::MismatchIndicator(int n_T, int alarm_count)
    : n_T_(n_T), alarm_count_(alarm_count) {
  if (n_T < 1) throw InputError("mismatch indicator: n_T must be >= 1, got " + std::to_string(n_T));
  if (alarm_count < 1 || alarm_count > n_T)
    throw InputError("mismatch indicator: alarm_count must be in [1, n_T], got " +
                     std::to_string(alarm_count));
  ring_.assign(n_T, 0);
}

MismatchIndicator::Update MismatchIndicator::push(double score) {
  const std::uint8_t negative = score < 0 ? 1 : 0;  // false for NaN: a skipped window
  negatives_ += negative - ring_[next_];
  ring_[next_] = negative;
  next_ = (next_ + 1) % n_T_;
  const bool was = alarm_;
  alarm_ = negatives_ >= alarm_count_;
  return {indicator(), alarm_, alarm_ && !was};
}

std::vector<std::uint8_t> MismatchIndicator::history() const {
  std::vector<std::uint8_t> h(n_T_);
  for (int k = 0; k < n_T_; ++k) h[k] = ring_[(next_ + k) % n_T_];
  return h;
}

void MismatchIndicator::restore(const std::vector<std::uint8_t>& history, bool alarm) {
  if (static_cast<int>(history.size()) != n_T_)
    throw InputError("mismatch indicator: history has " + std::to_string(history.size()) +
                     " windows, expected n_T = " + std::to_string(n_T_));
  negatives_ = 0;
  for (int k = 0; k < n_T_; ++k) {
    if (history[k] > 1) throw InputError("mismatch indicator: history flags must be 0 or 1");
    ring_[k] = history[k];
    negatives_ += history[k];
  }
  next_ = 0;
  alarm_ = alarm;
}

}  // namespace mpmpp
