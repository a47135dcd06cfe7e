#pragma once
// The mismatch indicator of one monitored channel (paper eqs. 22-23) and its alarm rule.
//
// Every moving window pushes its SVM score h(x_t). The indicator is
//   s_t = |{ i in T_t : h(x_i) < 0 }| / n_T,   T_t = the last n_T windows up to t.
// Choices where eq. 23 is loose:
//  * T_t holds exactly n_T windows (t - n_T + 1 .. t), so s lies in [0, 1]; the paper's
//    {t - n_T, ..., t} has n_T + 1 elements but is divided by n_T.
//  * Windows before the first push (and training windows, whose score is 0 as in the
//    paper, eq. 22 gives sign 0) count as not negative. So in the first n_T windows after
//    training, s can only reach s_T once enough monitored windows are negative: a
//    conservative start, no alarm from a half-filled history.
//  * A skipped window (NaN score: data gap in the window) counts as not negative: a gap
//    gives no evidence of mismatch; it can delay an alarm, never create one.
// Alarm: active while negatives >= alarm_count (i.e. s >= s_T); it starts at the window
// where it becomes active and clears when s drops below s_T; a channel may alarm again.
// State is O(n_T) and fixed-size (a ring of flags), suited to streaming.
#include <cstdint>
#include <vector>

namespace mpmpp {

class MismatchIndicator {
 public:
  // n_T windows inspected, alarm when at least alarm_count of them are negative.
  MismatchIndicator(int n_T, int alarm_count);

  struct Update {
    double indicator;  // s after this window
    bool alarm;        // alarm active after this window
    bool started;      // this window started an alarm (inactive -> active)
  };
  // One window's score; score < 0 is negative, 0 (training) and NaN (skipped) are not.
  Update push(double score);

  double indicator() const { return static_cast<double>(negatives_) / n_T_; }
  bool alarm() const { return alarm_; }
  int n_T() const { return n_T_; }
  int alarm_count() const { return alarm_count_; }

  // Checkpoint: the ring of the last n_T negative flags (oldest first) and the alarm flag.
  std::vector<std::uint8_t> history() const;
  void restore(const std::vector<std::uint8_t>& history, bool alarm);

 private:
  int n_T_, alarm_count_;
  std::vector<std::uint8_t> ring_;  // negative flags, ring_[next_] is the oldest
  int next_ = 0;
  int negatives_ = 0;
  bool alarm_ = false;
};

}  // namespace mpmpp
