#pragma once
// Plant-side streaming front end of the trained MPM / noise-change detector.
//
// A StreamingDetector wraps a trained Detector (train_detector, or Detector::load of a file
// saved by Python or C++) and is fed one sample at a time, as a historian or an MPC monitoring
// service receives them. It keeps only the last window of samples (a ring buffer of window_samples
// rows; with DetectorConfig::pooled_windows, the span from the earliest pooled window on, whose
// estimates are recomputed from it) plus the n_T-window ring of each channel's indicator, so
// memory does not grow with the run length. Whenever a moving window completes (the first after
// window_samples samples, then every step_samples samples, exactly the windows of the batch
// Detector::monitor on the same series), it runs ARX-OE + the SVMs on that window
// (Detector::score_window) and returns the scores, indicator values and alarm state per channel.
// Results equal the batch path's bit for bit:
//   * the first pushed sample is the series' start: windows ending at or before
//     t0 + train_end_s (+ half a sample, as in monitor) are training windows, score 0;
//   * a window holding a missing value (NaN) or one ARX-OE cannot estimate is skipped:
//     NaN scores, reported with the reason, counted as not negative by the indicator.
// Time checks: each sample must come sample_time_s after the previous one (relative
// tolerance 1e-6, as validate_data); a gap or a step back is an InputError naming both
// times. A plant that lost samples pushes them as NaN rows (they are missing values) and
// keeps the windows aligned; the detector never invents data.
// Checkpoint: save_checkpoint writes the whole stream state (ring buffer, sample count,
// indicator rings, alarm flags) as versioned JSON atomically; load_checkpoint on a
// StreamingDetector built from the same detector file resumes so that every later window
// scores bit-identically to an uninterrupted run (doubles are written in shortest
// round-trip form, NaN as null). A checkpoint of another detector is refused.
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

#include "mpmpp/detector.hpp"
#include "mpmpp/mismatch_indicator.hpp"

namespace mpmpp {

// One completed moving window.
struct StreamWindow {
  int window = 0;                 // index since the stream's first sample (= batch window index)
  double start_s = 0, end_s = 0;  // first sample's time; last sample's time + sample time
  bool training = false;          // ends inside the training period: scores 0
  bool skipped = false;           // missing values in the window or ARX-OE failed: scores NaN
  std::string skip_reason;
  Eigen::VectorXd scores;         // per channel (Detector::channels() order), eq. 20
  Eigen::VectorXd indicator;      // per channel, eq. 23
  std::vector<bool> alarm;        // per channel: alarm active after this window
  std::vector<int> alarm_starts;  // channels whose alarm started at this window
};

class StreamingDetector {
 public:
  explicit StreamingDetector(Detector detector);
  static StreamingDetector load(const std::string& detector_path);  // Detector::load

  // One sample: time in seconds, u (num_inputs) and y (num_outputs) in the model's order,
  // NaN for a missing value. Returns true and fills `window` when this sample completes a
  // moving window; false otherwise (window untouched). InputError on wrong sizes, an
  // infinite value, a non-finite time or a time step other than sample_time_s; the stream
  // state is unchanged by a rejected sample.
  bool push(double time_s, const Eigen::Ref<const Eigen::VectorXd>& u,
            const Eigen::Ref<const Eigen::VectorXd>& y, StreamWindow& window);
  // A block of samples (rows); returns the windows it completed, in order. Checked as a
  // whole before any sample is taken, so a rejected block leaves the state unchanged.
  std::vector<StreamWindow> push_block(const Eigen::Ref<const Eigen::VectorXd>& time_s,
                                       const Eigen::Ref<const Eigen::MatrixXd>& u,
                                       const Eigen::Ref<const Eigen::MatrixXd>& y);

  std::string checkpoint_json() const;
  void save_checkpoint(const std::string& path) const;  // atomic: temporary file + rename
  // `source` names the text in error messages. InputError for another detector's
  // checkpoint, a newer format version, or a truncated / corrupt file.
  void restore_checkpoint_json(const std::string& text, const std::string& source);
  void load_checkpoint(const std::string& path);

  const Detector& detector() const { return detector_; }
  std::int64_t samples() const { return samples_; }  // pushed since the stream's start
  int windows() const { return windows_; }           // completed since the start
  int window_samples() const { return window_; }
  int step_samples() const { return step_; }
  // Every alarm flag, per channel, after the last completed window.
  std::vector<bool> alarm() const;

  static constexpr int kCheckpointVersion = 1;

 private:
  void check_sample(double time_s, double previous_time_s, bool first,
                    const Eigen::Ref<const Eigen::VectorXd>& u,
                    const Eigen::Ref<const Eigen::VectorXd>& y, const std::string& where) const;
  bool take(double time_s, const Eigen::Ref<const Eigen::VectorXd>& u,
            const Eigen::Ref<const Eigen::VectorXd>& y, StreamWindow& window);
  void complete_window(StreamWindow& window);
  // The window ending `back` samples before the newest one, oldest row first, into u and y.
  void unroll(int back, Eigen::MatrixXd& u, Eigen::MatrixXd& y) const;

  Detector detector_;
  std::uint64_t fingerprint_;  // FNV-1a of the detector file text: ties checkpoints to it
  WindowFeatures features_;    // ARX-OE workspace, reused window after window
  int window_, step_;
  int ring_;  // samples buffered: one window, or the pooled windows' span
  double sample_time_s_, train_end_abs_ = 0;
  // Ring buffer of the last ring_ samples: row next_ is the oldest once full.
  Eigen::VectorXd ring_time_;
  Eigen::MatrixXd ring_u_, ring_y_;
  int next_ = 0;
  std::int64_t samples_ = 0;
  int windows_ = 0;
  double t0_ = 0, last_time_ = 0;
  std::vector<MismatchIndicator> indicators_;
  Eigen::MatrixXd window_u_, window_y_;  // the completed window, oldest first (workspace)
};

}  // namespace mpmpp
