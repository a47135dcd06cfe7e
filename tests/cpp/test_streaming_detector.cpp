#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <unistd.h>

#include "mpmpp/data_io.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/model_io.hpp"
#include "mpmpp/streaming_detector.hpp"
#include "small_loop.hpp"

using namespace mpmpp;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string stream_data(const std::string& name) {
  return std::string(MPMPP_SOURCE_DIR) + "/tests/data/stream/" + name;
}
std::string temp_path(const std::string& name) { return std::string(::testing::TempDir()) + name; }

// Exact equality, NaN equal to NaN (skipped windows).
bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// Scores written by the (Release) Python build: bit-identical in an optimised build; a Debug
// or sanitizer build may round a kernel sum differently in the last bit, so there 1e-13.
bool same_as_release_file(double a, double b) {
#ifdef NDEBUG
  return same(a, b);
#else
  return same(a, b) || std::abs(a - b) <= 1e-13 * std::max(1.0, std::abs(b));
#endif
}

// Every window of a table of samples pushed one by one.
std::vector<StreamWindow> stream_all(StreamingDetector& s, const Eigen::VectorXd& t,
                                     const Eigen::MatrixXd& u, const Eigen::MatrixXd& y,
                                     Eigen::Index from = 0, Eigen::Index to = -1) {
  if (to < 0) to = t.size();
  std::vector<StreamWindow> out;
  StreamWindow w;
  for (Eigen::Index r = from; r < to; ++r)
    if (s.push(t[r], u.row(r).transpose(), y.row(r).transpose(), w)) out.push_back(w);
  return out;
}

using Series = test_loops::LoopSamples;

Series columns(const DataTable& d, const Model& m) {
  Series s{d.time_s, Eigen::MatrixXd(d.num_samples(), m.num_inputs()),
           Eigen::MatrixXd(d.num_samples(), m.num_outputs())};
  for (int j = 0; j < m.num_inputs(); ++j) s.u.col(j) = d.values.col(d.column(m.inputs[j]));
  for (int i = 0; i < m.num_outputs(); ++i) s.y.col(i) = d.values.col(d.column(m.outputs[i]));
  return s;
}

// A cheap detector for long streams: short windows, low ARX orders, random SVMs (the
// stream does not care how the SVMs were trained).
Detector cheap_detector(double train_end_s) {
  const Model m = test_loops::small_siso_model();
  const DetectorConfig c = test_loops::short_window_config(3000);
  WindowFeatures f(m, c);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<ChannelScorer> scorers;
  for (size_t k = 0; k < f.channels().size(); ++k) {
    const int d = f.feature_length(static_cast<int>(k));
    ChannelScorer s;
    s.feature_mean = Eigen::VectorXd::Zero(d);
    s.feature_scale = Eigen::VectorXd::Constant(d, 0.05);
    s.support_vectors = RowMatrixXd::NullaryExpr(5, d, [&] { return n(rng); });
    s.dual_coef = Eigen::VectorXd::Constant(5, 0.8);
    s.offset = 0.5;
    s.kernel_scale = 4.0 * d;
    s.nu = 0.5;
    s.n_train = 10;
    scorers.push_back(s);
  }
  return Detector(m, c, train_end_s, scorers);
}

long resident_kb() {
  std::ifstream f("/proc/self/statm");
  long size = 0, resident = 0;
  f >> size >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

}  // namespace

// --- equality with the batch path ---------------------------------------------------------

// The detector and data were written by Python (scripts/make_stream_test_data.py): the
// stream reproduces the batch scores bit for bit and `mpmpp detect`'s alarms.
TEST(StreamingDetector, PythonTrainedDetectorMatchesBatchScoresAndAlarms) {
  StreamingDetector s = StreamingDetector::load(stream_data("detector.json"));
  const Model& m = s.detector().model();
  const Series data = columns(read_csv(stream_data("data.csv")), m);
  const std::vector<StreamWindow> windows = stream_all(s, data.t, data.u, data.y);

  // Expected: the batch Python monitor of the saved detector (expected_scores.csv).
  std::ifstream f(stream_data("expected_scores.csv"));
  std::string line;
  std::getline(f, line);  // header
  const int nc = static_cast<int>(s.detector().channels().size());
  size_t row = 0, skipped = 0;
  while (std::getline(f, line)) {
    ASSERT_LT(row, windows.size());
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    cells.resize(3 + 2 * nc);
    auto num = [](const std::string& c) {
      return c.empty() ? kNaN : std::strtod(c.c_str(), nullptr);
    };
    const StreamWindow& w = windows[row];
    EXPECT_EQ(w.window, static_cast<int>(row));
    EXPECT_EQ(w.start_s, num(cells[1]));
    EXPECT_EQ(w.end_s, num(cells[2]));
    for (int k = 0; k < nc; ++k) {
      EXPECT_TRUE(same_as_release_file(w.scores[k], num(cells[3 + k])))
          << "window " << row << " channel " << k << ": " << w.scores[k] << " vs " << cells[3 + k];
      EXPECT_EQ(w.indicator[k], num(cells[3 + nc + k])) << "window " << row << " channel " << k;
    }
    skipped += w.skipped;
    ++row;
  }
  EXPECT_EQ(row, windows.size());
  EXPECT_GT(skipped, 0u);  // the data set's missing cells are exercised

  // Alarms: `mpmpp detect --json` (expected_alarms.csv), in window then channel order.
  std::ifstream fa(stream_data("expected_alarms.csv"));
  std::getline(fa, line);
  std::vector<std::string> expected, got;
  while (std::getline(fa, line)) expected.push_back(line);
  for (const auto& w : windows)
    for (int k : w.alarm_starts) {
      const MonitoredChannel& c = s.detector().channels()[k];
      char buf[256];
      std::snprintf(buf, sizeof buf, "%s,%s,%s,%.3f",
                    c.kind == MonitoredChannel::Kind::Process ? "process" : "noise",
                    m.outputs[c.output].c_str(), c.input >= 0 ? m.inputs[c.input].c_str() : "",
                    w.end_s);
      got.push_back(buf);
    }
  EXPECT_FALSE(expected.empty());
  EXPECT_EQ(got, expected);
}

// The same in C++ alone against Detector::monitor, on data with gaps in training and later:
// single lost samples (a window does without them) and runs of 15 (more than the tenth of a
// 120-row window it may lose: skipped).
TEST(StreamingDetector, MatchesBatchMonitorWithMissingValues) {
  const Detector d = cheap_detector(3600.0);
  Series data = test_loops::random_step_samples(d.model(), 2000, 3, 1000.0);
  data.y(100, 0) = kNaN;  // training
  data.u(900, 0) = kNaN;  // monitoring
  data.y(1500, 0) = kNaN;
  data.y.block(300, 0, 15, 1).setConstant(kNaN);   // training
  data.u.block(1200, 0, 15, 1).setConstant(kNaN);  // monitoring
  const DetectionResult batch = d.monitor(data.t, data.u, data.y);
  StreamingDetector s(d);
  const std::vector<StreamWindow> windows = stream_all(s, data.t, data.u, data.y);
  ASSERT_EQ(windows.size(), batch.windows.size());
  int skipped = 0, alarms = 0;
  for (size_t w = 0; w < windows.size(); ++w) {
    EXPECT_EQ(windows[w].start_s, batch.windows[w].start_s);
    EXPECT_EQ(windows[w].end_s, batch.windows[w].end_s);
    EXPECT_EQ(windows[w].training, batch.training[w]);
    EXPECT_EQ(windows[w].skipped, batch.windows[w].skipped);
    EXPECT_EQ(windows[w].skip_reason, batch.windows[w].skip_reason);
    for (Eigen::Index k = 0; k < batch.scores.cols(); ++k) {
      EXPECT_TRUE(same(windows[w].scores[k], batch.scores(w, k))) << w << "," << k;
      EXPECT_EQ(windows[w].indicator[k], batch.indicator(w, k)) << w << "," << k;
    }
    skipped += windows[w].skipped;
    for (int k : windows[w].alarm_starts) {
      ASSERT_LT(static_cast<size_t>(alarms), batch.alarms.size());
      EXPECT_EQ(batch.alarms[alarms].window, static_cast<int>(w));
      EXPECT_EQ(batch.alarms[alarms].channel, k);
      ++alarms;
    }
  }
  EXPECT_EQ(skipped, 2 * 2);  // 600 s windows, 300 s step: each run is in 2 windows
  EXPECT_EQ(static_cast<size_t>(alarms), batch.alarms.size());
}

TEST(StreamingDetector, BlockPushEqualsSamplePush) {
  const Detector d = cheap_detector(1800.0);
  const Series data = test_loops::random_step_samples(d.model(), 700, 5);
  StreamingDetector one(d), block(d);
  const auto a = stream_all(one, data.t, data.u, data.y);
  std::vector<StreamWindow> b;
  for (Eigen::Index r = 0; r < 700; r += 97) {  // blocks that straddle window boundaries
    const Eigen::Index n = std::min<Eigen::Index>(97, 700 - r);
    for (auto& w :
         block.push_block(data.t.segment(r, n), data.u.middleRows(r, n), data.y.middleRows(r, n)))
      b.push_back(w);
  }
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), static_cast<size_t>((700 - 120) / 60 + 1));
  for (size_t w = 0; w < a.size(); ++w) {
    EXPECT_EQ(a[w].end_s, b[w].end_s);
    for (Eigen::Index k = 0; k < a[w].scores.size(); ++k)
      EXPECT_TRUE(same(a[w].scores[k], b[w].scores[k]));
    EXPECT_EQ(a[w].alarm, b[w].alarm);
  }
}

// --- checkpoint / restart -----------------------------------------------------------------

TEST(StreamingDetector, CheckpointRestartGivesBitIdenticalScores) {
  const std::string det_path = stream_data("detector.json");
  StreamingDetector whole = StreamingDetector::load(det_path);
  const Model& m = whole.detector().model();
  const Series data = columns(read_csv(stream_data("data.csv")), m);
  const auto reference = stream_all(whole, data.t, data.u, data.y);
  // Before the first window is full, mid-step, just before and just after a window completes,
  // late in the run.
  for (Eigen::Index cut : {Eigen::Index(700), Eigen::Index(5003), Eigen::Index(1440 + 60 * 50 - 1),
                           Eigen::Index(1440 + 60 * 50), Eigen::Index(9001)}) {
    SCOPED_TRACE("cut at sample " + std::to_string(cut));
    StreamingDetector first = StreamingDetector::load(det_path);
    const auto before = stream_all(first, data.t, data.u, data.y, 0, cut);
    const std::string ck = temp_path("stream_checkpoint.json");
    first.save_checkpoint(ck);
    StreamingDetector resumed = StreamingDetector::load(det_path);  // a "new process"
    resumed.load_checkpoint(ck);
    EXPECT_EQ(resumed.samples(), cut);
    EXPECT_EQ(resumed.checkpoint_json(), first.checkpoint_json());
    const auto after = stream_all(resumed, data.t, data.u, data.y, cut);
    ASSERT_EQ(before.size() + after.size(), reference.size());
    for (size_t w = 0; w < after.size(); ++w) {
      const StreamWindow& r = reference[before.size() + w];
      EXPECT_EQ(after[w].window, r.window);
      EXPECT_EQ(after[w].alarm, r.alarm);
      EXPECT_EQ(after[w].alarm_starts, r.alarm_starts);
      for (Eigen::Index k = 0; k < r.scores.size(); ++k) {
        EXPECT_TRUE(same(after[w].scores[k], r.scores[k])) << "window " << r.window;
        EXPECT_EQ(after[w].indicator[k], r.indicator[k]) << "window " << r.window;
      }
    }
  }
}

TEST(StreamingDetector, CheckpointErrorsAreClearAndLeaveStateUnchanged) {
  const Detector d = cheap_detector(1800.0);
  const Series data = test_loops::random_step_samples(d.model(), 300, 9);
  StreamingDetector s(d);
  stream_all(s, data.t, data.u, data.y, 0, 200);
  const std::string good = s.checkpoint_json();
  auto message = [&](const std::string& text) {
    try {
      s.restore_checkpoint_json(text, "ck.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(good.substr(0, good.size() / 2)).find("ck.json: not a complete JSON"),
            std::string::npos);
  EXPECT_NE(message("{\"format\": \"something\"}").find("not an mpmpp stream checkpoint"),
            std::string::npos);
  std::string newer = good;
  newer.replace(newer.find("\"version\":1"), 11, "\"version\":99");
  EXPECT_NE(message(newer).find("version 99 is not supported"), std::string::npos);
  // Another detector (other train_end_s): refused.
  StreamingDetector other(cheap_detector(2400.0));
  EXPECT_THROW(other.restore_checkpoint_json(good, "ck.json"), InputError);
  try {
    other.restore_checkpoint_json(good, "ck.json");
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another detector"), std::string::npos);
  }
  std::string wrong_count = good;
  wrong_count.replace(wrong_count.find("\"samples\":200"), 13, "\"samples\":201");
  EXPECT_NE(message(wrong_count).find("ck.json"), std::string::npos);
  EXPECT_EQ(s.checkpoint_json(), good);  // untouched by every failed restore
  EXPECT_THROW(s.load_checkpoint(temp_path("no_such_checkpoint.json")), InputError);
}

// --- input checks -------------------------------------------------------------------------

TEST(StreamingDetector, TimeGapsAndBadSamplesAreClearErrors) {
  StreamingDetector s(cheap_detector(1800.0));
  Eigen::VectorXd u(1), y(1), u2(2);
  u << 0.1;
  y << 0.2;
  u2 << 0.1, 0.2;
  StreamWindow w;
  auto message = [&](double t, const Eigen::VectorXd& uu, const Eigen::VectorXd& yy) {
    try {
      s.push(t, uu, yy, w);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(100.0, u, y), "no error");
  EXPECT_EQ(message(105.0, u, y), "no error");
  EXPECT_NE(message(120.0, u, y)
                .find("time_s: sample at 120 s comes 15 s after the previous one (105 s)"),
            std::string::npos);
  EXPECT_NE(message(120.0, u, y).find("push missing samples as NaN rows"), std::string::npos);
  EXPECT_NE(message(105.0, u, y).find("time_s"), std::string::npos);  // repeated time
  EXPECT_NE(message(kNaN, u, y).find("time_s: must be a finite"), std::string::npos);
  EXPECT_NE(message(110.0, u2, y).find("u: 2 values, the model has 1 inputs"), std::string::npos);
  Eigen::VectorXd inf(1);
  inf << std::numeric_limits<double>::infinity();
  EXPECT_NE(message(110.0, u, inf).find("y: output y is infinite"), std::string::npos);
  EXPECT_EQ(s.samples(), 2);  // rejected samples leave no trace
  Eigen::VectorXd nan(1);
  nan << kNaN;
  EXPECT_EQ(message(110.000001, nan, y), "no error");  // within 1e-6 relative; NaN is missing
  // A block is checked whole before any sample is taken.
  Eigen::VectorXd t(3);
  t << 115.0, 120.0, 130.0;
  EXPECT_THROW(s.push_block(t, Eigen::MatrixXd::Zero(3, 1), Eigen::MatrixXd::Zero(3, 1)),
               InputError);
  try {
    s.push_block(t, Eigen::MatrixXd::Zero(3, 1), Eigen::MatrixXd::Zero(3, 1));
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("push_block: row 2: time_s", 0), 0u) << e.what();
  }
  EXPECT_EQ(s.samples(), 3);
}

// --- memory -------------------------------------------------------------------------------

// 7 days at 5 s (120,960 samples, 2016 windows): heap in use and resident memory after day 7
// equal those after day 2 within a few KB (the stream keeps one window of samples, whatever
// the run length).
TEST(StreamingDetector, MemoryStaysFlatOverSevenDays) {
  const Detector d = cheap_detector(3600.0);
  StreamingDetector s(d);
  const Eigen::Index per_day = 86400 / 5;
  const Series day = test_loops::random_step_samples(d.model(), per_day, 11);
  StreamWindow w;
  // Heap in use (glibc) and resident memory after day 2 and after day 7, read right at the
  // day's end (before any other call allocates). Day 1 is warm-up: reused workspaces (the
  // skip reason, alarm lists) may still grow their capacity once there.
  std::size_t heap[2] = {0, 0};
  long rss[2] = {0, 0};
  int windows = 0, alarms = 0;
  for (int k = 0; k < 7; ++k) {
    for (Eigen::Index r = 0; r < per_day; ++r) {
      if (s.push(86400.0 * k + day.t[r], day.u.row(r).transpose(), day.y.row(r).transpose(), w)) {
        ++windows;
        alarms += static_cast<int>(w.alarm_starts.size());
      }
    }
    if (k == 1 || k == 6) {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || __GLIBC_MINOR__ >= 33)
      heap[k / 6] = mallinfo2().uordblks;
#endif
      rss[k / 6] = resident_kb();
    }
  }
  // Keeping even one byte per sample would add 5 x 17280 B = 84 KB; one double, 675 KB.
  EXPECT_LE(heap[1], heap[0] + 4096) << "heap in use after day 2 and day 7 (bytes)";
#ifndef __SANITIZE_ADDRESS__  // AddressSanitizer's quarantine keeps freed blocks resident
  EXPECT_LE(rss[1], rss[0] + 256) << "resident memory after day 2 and day 7 (KB)";
#endif
  EXPECT_EQ(s.samples(), 7 * per_day);
  EXPECT_EQ(windows, static_cast<int>((7 * per_day - 120) / 60 + 1));
  EXPECT_LT(s.checkpoint_json().size(), 64u * 1024u);  // the whole state: one window of samples
  RecordProperty("windows", windows);
  RecordProperty("alarms", alarms);
}
