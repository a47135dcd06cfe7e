#pragma once
// Every tuning parameter of the moving-window MPM / noise-change detector
// (paper Section 4, Tables 1 and 3), with the paper's two examples as presets
// (verbatim: paper_siso, paper_mimo; recommended: siso, mimo).
//
// Durations are in seconds and are converted to samples / windows with the
// model's sample time (window_samples(), step_samples(), inspection_windows());
// a duration that is not a whole number of samples (or of steps) is an InputError.
// JSON form (detector files, `mpmpp detect --config FILE`): the field names below;
// a config file may start from a preset, {"preset": "paper_siso", "alpha": 2.0},
// and unknown keys are an error.
#include <cstdint>
#include <string>
#include <vector>

namespace mpmpp {

// How the OE step parameterises each channel before it is expanded to FIR form (eq. 21).
enum class OeStructure {
  Foptd,  // b q^-d / (1 + f q^-1) with the nominal delay d (the paper's MD-process choice)
  Fir,    // fir_length coefficients after the nominal delay (Remark 3: no structure assumed)
};

// How the training-window estimates are enlarged into the SVM's training set (Sec. 4.2).
enum class Resampling {
  Independent,  // the paper: independent Gaussian per coefficient
  // mpmpp: one Gaussian with the coefficients' sample covariance, on channels whose training
  // period holds more non-overlapping windows than coefficients (a covariance from fewer is
  // singular); the others fall back to Independent. See resampling.hpp for why.
  Covariance,
  // mpmpp: one Gaussian with the sample covariance plus the estimator's own covariance (the
  // mean OE covariance sigma^2 (J'J)^-1 of the training windows), on process channels; and each
  // monitored window's deviation is measured in the precision of its own estimate
  // (ChannelScorer::reference_covariance). Needs OeStructure::Fir (the OE parameters are then
  // the features). Noise channels keep Independent. See detector.hpp for why.
  Estimator,
};

// How a process channel's windows are judged against the training period.
enum class ProcessTest {
  Svm,  // the paper: ARX-OE FIR estimates, one-class SVM on the resampled training cloud
  // mpmpp: the nominal model's output error regressed on directions of model change
  // (residual_regression.hpp), each window's coefficients compared with the training mean by
  // a Wald test at level window_significance.
  Residual,
};

// How a noise channel's windows are judged against the training period.
enum class NoiseTest {
  Svm,  // the paper: the ARX-OE estimate's A_i(q), one-class SVM on the resampled cloud
  // mpmpp: a_1..a_na of A(q) = 1/H with their least-squares covariance sigma^2 (Phi'Phi)^-1,
  // compared with the training mean by a Wald test at window_significance as
  // ProcessTest::Residual's channels are; A(q) is the ARX step's, which in closed loop also
  // carries the process's poles and so moves with the excitation.
  Wald,
  // mpmpp, the presets: the same Wald test on the disturbance's own A(q): the residual
  // regression's whitening polynomial of the output error y - G0 u (fitted after the window's
  // channel changes and trend are taken out); needs ProcessTest::Residual, and no ARX-OE step
  // is run. Tuning families, seeds 0-19 (docs/detection.md): false noise alarms in 9/140 runs
  // with Wald, 5/140 with Residual.
  Residual,
};

// Whether noise channels carry covariances and are judged by a Wald test.
inline bool is_wald(NoiseTest t) { return t != NoiseTest::Svm; }

struct DetectorConfig {
  double window_s = 7200.0;           // W_size: moving-window length
  double step_s = 300.0;              // W_step: moving-window step
  int arx_order_a = 9;                // n_a: order of each A_i(q) (high-order ARX, eq. 6 / 12)
  int arx_order_b = 9;                // n_b: order of each B_ij(q)
  double train_duration_s = 10800.0;  // T_train: used when the caller gives no training end
  double inspection_s = 7200.0;  // n_T as a duration: windows inspected by the indicator (eq. 23)
  double threshold = 0.95;       // s_T: alarm when the indicator s >= s_T
  double alpha = 1.5;            // widening of each coefficient's std in resampling (Sec. 4.2)
  double noise_alpha = 0.0;      // the same for the noise-model channels; 0 = alpha
  double nu = 0.5;               // one-class SVM nu (eqs. 16-19)
  double kernel_scale = 1.0;     // c in k(x, y) = exp(-||x - y||^2 / c) (eq. 15)
  // Fraction of resampled training models allowed to score negative. Negative = choose
  // it from outlier_fraction_grid by cv_folds-fold cross-validation (as the paper does).
  double outlier_fraction = -1.0;
  std::vector<double> outlier_fraction_grid{0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3};
  int cv_folds = 10;
  int fir_length = 0;          // m + 1 FIR coefficients per channel; 0 = until the
                               // nominal impulse response falls below 1% of its peak
  bool standardise = true;     // centre and scale the SVM features (see detector.cpp)
  int resampled_models = 300;  // synthetic models drawn per channel in resampling
  std::uint64_t seed = 0;      // resampling and cross-validation seed
  OeStructure oe_structure = OeStructure::Foptd;
  double arx_regularisation = 1e-4;  // delta of the paper's R_reg rule (Sec. 3.1)
  Resampling resampling = Resampling::Independent;
  ProcessTest process_test = ProcessTest::Svm;
  double window_significance = 0.01;  // Residual: a window is negative when its Wald p < this
  // Wald noise channels' window level (NoiseTest::Wald / Residual); 0 = window_significance.
  double noise_significance = 0.0;
  int laguerre_terms = 3;  // Residual: Laguerre directions per channel
  // Residual: order of the whitening A(q) for every output; 0 = arx_order_a, unless
  // residual_ar_orders is given.
  int residual_ar_order = 0;
  // Residual: the whitening order per output (one entry per model output), overriding
  // residual_ar_order. mpmpp.detect sets it from the training when residual_ar_order is 0 (the
  // presets): each output's disturbance order, by BIC on its training output error, at least 3
  // (python/mpmpp/disturbance.py). A whitening longer than the disturbance needs lets A(q)
  // absorb a process change, which under feedback alone is predictable from the output error's
  // past (docs/detection.md "The whitening order"). Empty = residual_ar_order.
  std::vector<int> residual_ar_orders;
  // Residual: per output (one entry per model output), the moving-average root c in [0, 1) of
  // its disturbance, H = (1 - c q^-1) / A(q): each window's output error and directions pass
  // 1 / (1 - c q^-1) before the AR whitening. mpmpp.detect sets it with residual_ar_orders (the
  // BIC choice on the training output error, python/mpmpp/disturbance.py; docs/detection.md
  // "A wandering disturbance"). Empty = 0 for every output.
  std::vector<double> residual_ma_roots;
  // Residual: at most this many breaks (a level shift and a hinge at one row: an unmeasured
  // step or ramp disturbance) fitted per window in the AR fit and the whitened regression
  // (residual_regression.hpp), each kept only when its chi-square(2) score passes
  // step_significance over the rows scanned (Bonferroni); 0 = none.
  int residual_steps = 0;
  double step_significance = 0.01;
  // Residual: samples whose innovation exceeds this many robust sigmas (1.4826 MAD) of a first
  // AR fit are outliers, and every row of the window's fits that reads one is left out; 0 = none.
  double outlier_sigmas = 0.0;
  // Residual: a process channel's Wald test judges the precision-weighted mean of the window's
  // coefficients and those of the pooled_windows - 1 disjoint windows before it (ending one,
  // two, ... window lengths earlier; window_pooling.hpp); 1 = the window alone.
  int pooled_windows = 1;
  NoiseTest noise_test = NoiseTest::Svm;
  // Residual: when > 0, also monitor every channel the model lacks (output i <- input j with no
  // process[i][j], "absent": the model claims no coupling), each by this many Laguerre
  // directions of u_j in the output's own time scale (residual_regression.hpp); 0 = not
  // monitored. A coupling that appears then has a channel of its own to alarm on; without one
  // it reaches the process test only through the output's modelled channels. The SVM process
  // test has no estimate for such a channel (ARX-OE fits the modelled ones), so with it none is
  // monitored whatever this says.
  int absent_channels = 0;
  // The absent channels' window level; 0 = window_significance.
  double absent_significance = 0.0;
  // Residual: when > 0, a process channel whose training agrees with the model is judged
  // against the model itself as well as against the training mean. Agreement: the channel's
  // coefficients pooled over the disjoint training windows that end at the training's last
  // window (window_pooling.hpp), Wald-tested against beta = 0 (the model), give p above this.
  // Such a channel's window is negative only when both tests reject: the one against the model
  // (no reference variance) at the window level and the one against the training mean at
  // training_confirmation (ChannelScorer::confirmation). 0 = the training mean alone (the
  // paper's reference: normal is what the training saw). The SVM process test has no such
  // reference, so with it this is not used.
  double model_reference_significance = 0.0;
  double training_confirmation = 0.05;

  // Table 1 (SISO MD example) and Table 3 (MIMO MD example), verbatim (alpha 1.5); the
  // choices the paper leaves open are documented next to their values in detector_config.cpp.
  static DetectorConfig paper_siso();
  static DetectorConfig paper_mimo();
  // Recommended settings for the same examples: the paper's tables with the changes that
  // measured better over many seeds (docs/detection.md); the defaults of detect and demo.
  static DetectorConfig siso();
  static DetectorConfig mimo();
  // "siso" | "mimo" | "paper_siso" | "paper_mimo"; InputError naming the preset otherwise.
  static DetectorConfig preset(const std::string& name);

  // InputError naming the first invalid field.
  void validate() const;
  // InputError unless residual_ar_orders and residual_ma_roots are each empty or have one entry
  // per output of the model.
  void check_whitening_entries(int num_outputs) const;
  // Residual: the whitening order of output `output` (of num_outputs): residual_ar_orders[output],
  // else residual_ar_order, else arx_order_a.
  int whitening_order(int output, int num_outputs) const;
  // Residual: the moving-average root of output `output`'s whitening, residual_ma_roots[output]
  // or 0 (check_whitening_entries first).
  double whitening_root(int output, int num_outputs) const;
  // Conversions at the model's sample time; InputError when not a whole number.
  int window_samples(double sample_time_s) const;
  int step_samples(double sample_time_s) const;
  int inspection_windows() const;  // n_T = inspection_s / step_s
  // Windows between a window and the disjoint one pooled with it: ceil(window / step).
  int pooling_lag(double sample_time_s) const;
  // Number of negative windows among the last n_T that raises an alarm:
  // the smallest k with k / n_T >= s_T (integer form avoids 23/24 >= 0.95 rounding doubts).
  int alarm_count() const;

  std::string to_json() const;
  // Parses a JSON object; "preset" (optional) gives the starting values.
  static DetectorConfig from_json(const std::string& text);
};

const char* to_string(OeStructure s);
OeStructure oe_structure_from_string(const std::string& s);
const char* to_string(Resampling r);
Resampling resampling_from_string(const std::string& s);
const char* to_string(ProcessTest t);
ProcessTest process_test_from_string(const std::string& s);
const char* to_string(NoiseTest t);
NoiseTest noise_test_from_string(const std::string& s);

}  // namespace mpmpp
