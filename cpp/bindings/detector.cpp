// Thin bindings of the detector core: config, indicator, window features, scorers, Detector.
#include "mpmpp/detector.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "mpmpp/chi_square.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/mismatch_indicator.hpp"
#include "mpmpp/residual_regression.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

namespace {

py::dict window_dict(const FeatureWindow& w) {
  py::dict d;
  d["first"] = w.first;
  d["start_s"] = w.start_s;
  d["end_s"] = w.end_s;
  d["skipped"] = w.skipped;
  d["skip_reason"] = w.skip_reason;
  return d;
}

py::list windows_list(const std::vector<FeatureWindow>& ws) {
  py::list l;
  for (const auto& w : ws) l.append(window_dict(w));
  return l;
}

}  // namespace

void bind_detector(py::module_& m) {
  m.def("chi_square_survival", &chi_square_survival, py::arg("x"), py::arg("dof"),
        "P(X > x) for X ~ chi-square(dof)");
  m.def("chi_square_log_survival", &chi_square_log_survival, py::arg("x"), py::arg("dof"),
        "log P(X > x) for X ~ chi-square(dof), finite where P underflows");
  m.def(
      "residual_regression",
      [](const Model& model, int output, std::vector<int> inputs, const DetectorConfig& config,
         const Eigen::VectorXd& y, const Eigen::MatrixXd& u) {
        const ResidualRegression r(model, output, std::move(inputs), config);
        std::vector<Eigen::VectorXd> beta;
        std::vector<Eigen::MatrixXd> covariance;
        std::string reason;
        if (!r.estimate(y, u, beta, covariance, &reason)) throw NumericalError(reason);
        return py::make_tuple(beta, covariance, r.settling_samples());
      },
      py::arg("model"), py::arg("output"), py::arg("inputs"), py::arg("config"), py::arg("y"),
      py::arg("u"),
      "One window's residual regression (residual_regression.hpp): per input the coefficients, "
      "their covariance, and the settling samples dropped");

  py::class_<DetectorConfig>(
      m, "DetectorConfig",
      "Every detector parameter (paper Tables 1 and 3); see detector_config.hpp")
      .def(py::init<>())
      .def_readwrite("window_s", &DetectorConfig::window_s)
      .def_readwrite("step_s", &DetectorConfig::step_s)
      .def_readwrite("arx_order_a", &DetectorConfig::arx_order_a)
      .def_readwrite("arx_order_b", &DetectorConfig::arx_order_b)
      .def_readwrite("train_duration_s", &DetectorConfig::train_duration_s)
      .def_readwrite("inspection_s", &DetectorConfig::inspection_s)
      .def_readwrite("threshold", &DetectorConfig::threshold)
      .def_readwrite("alpha", &DetectorConfig::alpha)
      .def_readwrite("noise_alpha", &DetectorConfig::noise_alpha)
      .def_readwrite("nu", &DetectorConfig::nu)
      .def_readwrite("kernel_scale", &DetectorConfig::kernel_scale)
      .def_readwrite("outlier_fraction", &DetectorConfig::outlier_fraction)
      .def_readwrite("outlier_fraction_grid", &DetectorConfig::outlier_fraction_grid)
      .def_readwrite("cv_folds", &DetectorConfig::cv_folds)
      .def_readwrite("fir_length", &DetectorConfig::fir_length)
      .def_readwrite("standardise", &DetectorConfig::standardise)
      .def_readwrite("resampled_models", &DetectorConfig::resampled_models)
      .def_readwrite("seed", &DetectorConfig::seed)
      .def_property(
          "oe_structure",
          [](const DetectorConfig& c) { return std::string(to_string(c.oe_structure)); },
          [](DetectorConfig& c, const std::string& s) {
            c.oe_structure = oe_structure_from_string(s);
          })
      .def_property(
          "resampling",
          [](const DetectorConfig& c) { return std::string(to_string(c.resampling)); },
          [](DetectorConfig& c, const std::string& s) { c.resampling = resampling_from_string(s); })
      .def_property(
          "process_test",
          [](const DetectorConfig& c) { return std::string(to_string(c.process_test)); },
          [](DetectorConfig& c, const std::string& s) {
            c.process_test = process_test_from_string(s);
          })
      .def_readwrite("window_significance", &DetectorConfig::window_significance)
      .def_readwrite("laguerre_terms", &DetectorConfig::laguerre_terms)
      .def_readwrite("residual_ar_order", &DetectorConfig::residual_ar_order)
      .def_readwrite("residual_ar_orders", &DetectorConfig::residual_ar_orders)
      .def_readwrite("residual_ma_roots", &DetectorConfig::residual_ma_roots)
      .def_readwrite("residual_steps", &DetectorConfig::residual_steps)
      .def_readwrite("step_significance", &DetectorConfig::step_significance)
      .def_readwrite("outlier_sigmas", &DetectorConfig::outlier_sigmas)
      .def_readwrite("pooled_windows", &DetectorConfig::pooled_windows)
      .def_readwrite("absent_channels", &DetectorConfig::absent_channels)
      .def_readwrite("absent_significance", &DetectorConfig::absent_significance)
      .def_readwrite("model_reference_significance", &DetectorConfig::model_reference_significance)
      .def_readwrite("training_confirmation", &DetectorConfig::training_confirmation)
      .def_readwrite("noise_significance", &DetectorConfig::noise_significance)
      .def_property(
          "noise_test",
          [](const DetectorConfig& c) { return std::string(to_string(c.noise_test)); },
          [](DetectorConfig& c, const std::string& s) { c.noise_test = noise_test_from_string(s); })
      .def_readwrite("arx_regularisation", &DetectorConfig::arx_regularisation)
      .def_static("paper_siso", &DetectorConfig::paper_siso)
      .def_static("paper_mimo", &DetectorConfig::paper_mimo)
      .def_static("siso", &DetectorConfig::siso)
      .def_static("mimo", &DetectorConfig::mimo)
      .def_static("preset", &DetectorConfig::preset, py::arg("name"))
      .def_static("from_json", &DetectorConfig::from_json, py::arg("text"))
      .def("to_json", &DetectorConfig::to_json)
      .def("validate", &DetectorConfig::validate)
      .def("window_samples", &DetectorConfig::window_samples, py::arg("sample_time_s"))
      .def("step_samples", &DetectorConfig::step_samples, py::arg("sample_time_s"))
      .def("inspection_windows", &DetectorConfig::inspection_windows)
      .def("alarm_count", &DetectorConfig::alarm_count)
      .def("pooling_lag", &DetectorConfig::pooling_lag, py::arg("sample_time_s"))
      .def("__repr__",
           [](const DetectorConfig& c) { return "DetectorConfig(" + c.to_json() + ")"; });

  py::class_<MismatchIndicator>(m, "MismatchIndicator",
                                "Indicator of eq. 23 and its alarm rule, one channel")
      .def(py::init<int, int>(), py::arg("n_T"), py::arg("alarm_count"))
      .def(
          "push",
          [](MismatchIndicator& self, double score) {
            auto u = self.push(score);
            return py::make_tuple(u.indicator, u.alarm, u.started);
          },
          py::arg("score"), "-> (indicator, alarm, started)")
      .def_property_readonly("indicator", &MismatchIndicator::indicator)
      .def_property_readonly("alarm", &MismatchIndicator::alarm)
      .def("history", &MismatchIndicator::history)
      .def("restore", &MismatchIndicator::restore, py::arg("history"), py::arg("alarm"));

  py::class_<WindowFeatures::Series>(m, "WindowSeries",
                                     "ARX-OE features of every moving window of a series")
      .def_property_readonly(
          "windows", [](const WindowFeatures::Series& s) { return windows_list(s.windows); })
      .def_readonly("features", &WindowFeatures::Series::features,
                    "per channel: windows x feature length (NaN rows for skipped windows)")
      .def_readonly("covariances", &WindowFeatures::Series::covariances,
                    "resampling 'estimator' only: per channel, windows x d^2 feature covariances "
                    "(row-major)");

  py::class_<WindowFeatures>(m, "WindowFeatures",
                             "Per-window ARX-OE features per monitored channel")
      .def(py::init<const Model&, const DetectorConfig&>(), py::arg("model"), py::arg("config"))
      .def_property_readonly(
          "channels",
          [](const WindowFeatures& f) {
            py::list l;
            for (const auto& c : f.channels())
              l.append(
                  py::make_tuple(c.kind == MonitoredChannel::Kind::Process ? "process" : "noise",
                                 c.output, c.input));
            return l;
          })
      .def("feature_length", &WindowFeatures::feature_length, py::arg("channel"))
      .def_property_readonly("window_samples", &WindowFeatures::window_samples)
      .def_property_readonly("step_samples", &WindowFeatures::step_samples)
      .def("extract_series", &WindowFeatures::extract_series, py::arg("time_s"), py::arg("u"),
           py::arg("y"), py::call_guard<py::gil_scoped_release>());

  py::class_<ChannelScorer>(m, "ChannelScorer",
                            "Standardisation + trained one-class SVM of one channel")
      .def(py::init<>())
      .def_readwrite("feature_mean", &ChannelScorer::feature_mean)
      .def_readwrite("feature_scale", &ChannelScorer::feature_scale)
      .def_readwrite("feature_decorrelation", &ChannelScorer::feature_decorrelation)
      .def_readwrite("reference_covariance", &ChannelScorer::reference_covariance)
      .def_readwrite("mean_covariance", &ChannelScorer::mean_covariance)
      .def_readwrite("significance", &ChannelScorer::significance)
      .def_readwrite("confirmation", &ChannelScorer::confirmation)
      .def_readwrite("model_p_value", &ChannelScorer::model_p_value)
      .def_readwrite("support_vectors", &ChannelScorer::support_vectors)
      .def_readwrite("dual_coef", &ChannelScorer::dual_coef)
      .def_readwrite("offset", &ChannelScorer::offset)
      .def_readwrite("kernel_scale", &ChannelScorer::kernel_scale)
      .def_readwrite("nu", &ChannelScorer::nu)
      .def_readwrite("n_train", &ChannelScorer::n_train)
      .def_readwrite("training_windows", &ChannelScorer::training_windows)
      .def_readwrite("outlier_fraction", &ChannelScorer::outlier_fraction)
      .def_readwrite("cv_accuracy", &ChannelScorer::cv_accuracy)
      .def("score_rows", &ChannelScorer::score_rows, py::arg("X"),
           py::arg("covariances") = Eigen::MatrixXd());

  py::class_<DetectionResult>(m, "DetectionResult")
      .def_property_readonly("windows",
                             [](const DetectionResult& r) { return windows_list(r.windows); })
      .def_readonly("training", &DetectionResult::training)
      .def_readonly("scores", &DetectionResult::scores)
      .def_readonly("indicator", &DetectionResult::indicator)
      .def_property_readonly("alarms", [](const DetectionResult& r) {
        py::list l;
        for (const auto& a : r.alarms) l.append(py::make_tuple(a.channel, a.window, a.start_s));
        return l;
      });

  py::class_<Detector>(m, "Detector", "Trained MPM / noise-change detector (see detector.hpp)")
      .def(py::init<Model, DetectorConfig, double, std::vector<ChannelScorer>>(), py::arg("model"),
           py::arg("config"), py::arg("train_end_s"), py::arg("scorers"))
      .def("monitor",
           py::overload_cast<const Eigen::Ref<const Eigen::VectorXd>&,
                             const Eigen::Ref<const Eigen::MatrixXd>&,
                             const Eigen::Ref<const Eigen::MatrixXd>&>(&Detector::monitor,
                                                                       py::const_),
           py::arg("time_s"), py::arg("u"), py::arg("y"), py::call_guard<py::gil_scoped_release>())
      .def("monitor_series",
           py::overload_cast<const WindowFeatures::Series&>(&Detector::monitor, py::const_),
           py::arg("series"), py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("model", &Detector::model)
      .def_property_readonly("config", &Detector::config)
      .def_property_readonly("train_end_s", &Detector::train_end_s)
      .def_property_readonly("scorers", &Detector::scorers)
      .def("to_json", &Detector::to_json)
      .def_static("from_json", &Detector::from_json, py::arg("text"),
                  py::arg("source") = "<string>")
      .def("save", &Detector::save, py::arg("path"))
      .def_static("load", &Detector::load, py::arg("path"));
}

}  // namespace mpmpp::bindings
