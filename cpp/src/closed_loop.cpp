#include "mpmpp/closed_loop.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <utility>

#include "mpmpp/detail/incremental_filter.hpp"
#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

using detail::IncrementalFilter;

// Standard normal draws by Box-Muller on mt19937_64's raw bits: unlike
// std::normal_distribution, the sequence is the same on every standard library.
class GaussianSource {
 public:
  explicit GaussianSource(std::uint64_t seed) : bits_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(bits_() >> 11) + 0.5) * 0x1.0p-53;  // (0, 1)
    const double u2 = static_cast<double>(bits_() >> 11) * 0x1.0p-53;
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double phi = 6.283185307179586 * u2;
    spare_ = r * std::sin(phi);
    has_spare_ = true;
    return r * std::cos(phi);
  }

 private:
  std::mt19937_64 bits_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

void check_noise(const TransferFunction& h, const std::string& at) {
  if (!h.is_stable()) throw InputError(at + " noise model must be stable");
}

// Filter a channel's replacement over the recorded history (column `col` of `history`,
// samples 0..t-1 shifted by one: sample tau uses x(tau-1), zero before the start).
IncrementalFilter replayed(const TransferFunction& advanced, const Eigen::MatrixXd& history,
                           int col, int t) {
  IncrementalFilter f(advanced);
  for (int tau = 0; tau < t; ++tau) f.step(tau == 0 ? 0.0 : history(tau - 1, col));
  return f;
}

}  // namespace

SimulationResult simulate_closed_loop(const ClosedLoopConfig& cfg) {
  const Model& model = cfg.model;
  const Plant& plant = cfg.plant;
  const int ny = model.num_outputs(), nu = model.num_inputs();
  const int nx = static_cast<int>(plant.extra.size());
  const int n = cfg.num_samples;
  if (n < 1) throw InputError("duration must give at least one sample");
  if (static_cast<int>(plant.process.size()) != ny)
    throw InputError("truth process must have one row per output");
  for (const auto& row : plant.process)
    if (static_cast<int>(row.size()) != nu)
      throw InputError("truth process must have one entry per input in every row");
  if (static_cast<int>(plant.noise.size()) != ny)
    throw InputError("truth noise must have one model per output");
  if (plant.sigma.size() != ny) throw InputError("truth sigma must have one value per output");
  for (int i = 0; i < ny; ++i) {
    if (!(plant.sigma[i] >= 0.0) || !std::isfinite(plant.sigma[i]))
      throw InputError("truth sigma of " + model.outputs[i] + " must be a finite value >= 0");
    check_noise(plant.noise[i], "truth " + model.outputs[i]);
  }
  const bool has_extra_channels = !plant.extra_process.empty();
  if (has_extra_channels) {
    if (static_cast<int>(plant.extra_process.size()) != ny)
      throw InputError("truth extra channels must have one row per output");
    for (const auto& row : plant.extra_process)
      if (static_cast<int>(row.size()) != nx)
        throw InputError("truth extra channels must have one entry per extra variable");
  }
  for (const ExtraVariable& x : plant.extra) {
    if (!(x.sigma >= 0.0) || !std::isfinite(x.sigma) || !std::isfinite(x.operating_point))
      throw InputError("extra variable " + x.name +
                       ": sigma >= 0 and operating_point must be finite");
    check_noise(x.noise, "extra variable " + x.name);
  }
  if (!plant.actuators.empty() && static_cast<int>(plant.actuators.size()) != nu)
    throw InputError("truth actuators must have one entry per input");
  for (int j = 0; j < static_cast<int>(plant.actuators.size()); ++j)
    check_actuator(plant.actuators[j], "actuator of " + model.inputs[j]);

  Eigen::VectorXd u0 = cfg.u_operating.size() ? cfg.u_operating : cfg.tuning.mv_target;
  if (u0.size() != nu)
    throw InputError("operating inputs (MV targets) must have one value per input");
  Eigen::VectorXd y0 = cfg.y_operating.size() ? cfg.y_operating : cfg.tuning.cv_target;
  if (y0.size() != ny)
    throw InputError("operating outputs (CV targets) must have one value per output");
  if (!u0.allFinite() || !y0.allFinite()) throw InputError("operating point must be finite");

  // In sample order, ties in list order; sorted by index (a stable sort moving the Events
  // themselves trips GCC 12's -Wmaybe-uninitialized on their optional channel).
  std::vector<size_t> order(cfg.events.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&cfg](size_t a, size_t b) {
    return cfg.events[a].sample < cfg.events[b].sample;
  });
  std::vector<Event> events;
  events.reserve(order.size());
  for (size_t k : order) events.push_back(cfg.events[k]);
  for (const Event& ev : events) {
    if (ev.sample < 0 || ev.sample >= n) throw InputError("event sample outside the simulation");
    const bool needs_output = ev.kind != EventKind::Actuator && ev.kind != EventKind::MvTarget;
    const bool needs_input = ev.kind == EventKind::Process || ev.kind == EventKind::Actuator ||
                             ev.kind == EventKind::MvTarget;
    if (needs_output && (ev.output < 0 || ev.output >= ny))
      throw InputError("event output index out of range");
    if (needs_input && (ev.input < 0 || ev.input >= nu))
      throw InputError("event input index out of range");
    if (ev.kind == EventKind::ExtraProcess && (ev.input < 0 || ev.input >= nx))
      throw InputError("event extra variable index out of range");
    if (ev.kind == EventKind::Noise) {
      if (!ev.model) throw InputError("noise event needs a model");
      check_noise(*ev.model, "event");
    }
    if (ev.kind == EventKind::Sigma && (!(ev.value >= 0.0) || !std::isfinite(ev.value)))
      throw InputError("sigma event value must be a finite value >= 0");
    if (!std::isfinite(ev.value) || !std::isfinite(ev.rate))
      throw InputError("event values must be finite");
    if (ev.kind == EventKind::Actuator) check_actuator(ev.actuator, "event actuator");
    if (ev.fresh && ev.kind != EventKind::Process)
      throw InputError("event fresh: only a process (channel) event switches fresh");
  }

  if (!(plant.outlier_probability >= 0.0 && plant.outlier_probability <= 1.0))
    throw InputError("truth outlier probability must lie in [0, 1]");
  if (plant.outlier_probability > 0.0 &&
      (plant.outlier_size.size() != ny || !plant.outlier_size.allFinite()))
    throw InputError("truth outlier sizes must be finite, one per output");

  auto check_sequence = [n](const Eigen::MatrixXd& m, int cols, const std::string& what,
                            const std::string& per) {
    if (m.size() != 0 && (m.rows() != n || m.cols() != cols || !m.allFinite()))
      throw InputError(what + " must be finite, one row per sample and one column per " + per);
  };
  check_sequence(cfg.output_disturbance, ny, "output_disturbance", "output");
  check_sequence(cfg.position_noise, nu, "position_noise", "input");

  const bool pid_control = !cfg.pid_loops.empty();
  if (pid_control && cfg.record_qps)
    throw InputError("record_qps needs the MPC (no QPs under PID control)");
  for (const Event& ev : events)
    if (pid_control && ev.kind == EventKind::MvTarget)
      throw InputError("mv_target events need the MPC");
  std::optional<Mpc> mpc;
  std::optional<PidController> pid;
  if (pid_control)
    pid.emplace(cfg.pid_loops, ny, model.sample_time_s, u0, y0);
  else
    mpc.emplace(model, cfg.tuning, u0, cfg.qp_settings);

  // Truth filters, all advanced one sample: y(t) is formed from inputs up to t-1.
  auto channel = [](const std::optional<TransferFunction>& g, const std::string& what) {
    return g ? std::optional<IncrementalFilter>(
                   IncrementalFilter(detail::advanced_one_sample(*g, what)))
             : std::nullopt;
  };
  std::vector<std::optional<IncrementalFilter>> g0(static_cast<size_t>(ny) * nu),
      gx(static_cast<size_t>(ny) * nx);
  for (int i = 0; i < ny; ++i) {
    for (int j = 0; j < nu; ++j)
      g0[i * nu + j] = channel(plant.process[i][j],
                               "truth channel " + model.outputs[i] + " <- " + model.inputs[j]);
    if (has_extra_channels)
      for (int k = 0; k < nx; ++k)
        gx[i * nx + k] = channel(plant.extra_process[i][k], "truth channel " + model.outputs[i] +
                                                                " <- " + plant.extra[k].name);
  }
  std::vector<IncrementalFilter> h0, hx;
  std::vector<std::pair<int, IncrementalFilter>> fading;  // (output, channel replaced `fresh`)
  for (int i = 0; i < ny; ++i) h0.emplace_back(plant.noise[i]);
  for (int k = 0; k < nx; ++k) hx.emplace_back(plant.extra[k].noise);
  Eigen::VectorXd sigma = plant.sigma, drift = Eigen::VectorXd::Zero(ny),
                  slope = Eigen::VectorXd::Zero(ny);
  std::vector<Actuator> actuators(nu);
  for (int j = 0; j < nu; ++j) {
    if (!plant.actuators.empty()) actuators[j].set(plant.actuators[j]);
    actuators[j].start(u0[j]);
  }

  SimulationResult res;
  res.u.resize(n, nu);
  res.u_actual.resize(n, nu);
  res.y.resize(n, ny);
  res.setpoint.resize(n, ny);
  res.extra.resize(n, nx);
  Eigen::MatrixXd ua_dev(n, nu), x_dev(n, nx), innovation(n, ny);  // histories for replays
  if (cfg.record_qps) {
    res.qp_P = mpc->qp_P();
    res.qp_A = mpc->qp_A();
    res.qp_q.resize(n, res.qp_P.rows());
    res.qp_l.resize(n, res.qp_A.rows());
    res.qp_u.resize(n, res.qp_A.rows());
  }
  Eigen::VectorXd cv_target = pid_control ? y0 : cfg.tuning.cv_target, y(ny);
  GaussianSource gauss(cfg.seed);
  std::mt19937_64 outlier_bits(cfg.seed ^ 0x9e3779b97f4a7c15ULL);
  size_t next_event = 0;

  for (int t = 0; t < n; ++t) {
    for (; next_event < events.size() && events[next_event].sample == t; ++next_event) {
      const Event& ev = events[next_event];
      const int i = ev.output, j = ev.input;
      switch (ev.kind) {
        case EventKind::Process: {
          const std::string what = "event channel " + model.outputs[i] + " <- " + model.inputs[j];
          std::optional<IncrementalFilter>& g = g0[i * nu + j];
          if (ev.fresh && g) fading.emplace_back(i, std::move(*g));
          if (!ev.model) {
            g.reset();
            break;
          }
          const TransferFunction advanced = detail::advanced_one_sample(*ev.model, what);
          g = ev.fresh ? IncrementalFilter(advanced) : replayed(advanced, ua_dev, j, t);
          break;
        }
        case EventKind::ExtraProcess: {
          const std::string what =
              "event channel " + model.outputs[i] + " <- " + plant.extra[j].name;
          gx[i * nx + j] = ev.model
                               ? std::optional<IncrementalFilter>(replayed(
                                     detail::advanced_one_sample(*ev.model, what), x_dev, j, t))
                               : std::nullopt;
          break;
        }
        case EventKind::Noise: {
          // Noise filters take e(t) itself (not advanced): replay the innovations 0..t-1.
          IncrementalFilter h(*ev.model);
          for (int tau = 0; tau < t; ++tau) h.step(innovation(tau, i));
          h0[i] = h;
          break;
        }
        case EventKind::Sigma:
          sigma[i] = ev.value;
          break;
        case EventKind::Drift:
          drift[i] += ev.value;
          slope[i] = ev.rate;
          break;
        case EventKind::Actuator:
          actuators[j].set(ev.actuator);
          break;
        case EventKind::CvTarget:
          cv_target[i] = ev.value;
          if (pid)
            pid->set_setpoint(i, ev.value);
          else
            mpc->set_cv_target(i, ev.value);
          break;
        case EventKind::MvTarget:
          mpc->set_mv_target(j, ev.value);
          break;
      }
    }
    // Draw order per sample is fixed: the outputs' innovations, then the extra variables'.
    for (int i = 0; i < ny; ++i) innovation(t, i) = sigma[i] * gauss();
    for (int k = 0; k < nx; ++k) {
      const double x = hx[k].step(plant.extra[k].sigma * gauss());
      x_dev(t, k) = x;
      res.extra(t, k) = plant.extra[k].operating_point + x;
    }
    for (int i = 0; i < ny; ++i) {
      double yi = y0[i] + h0[i].step(innovation(t, i)) + drift[i];
      if (cfg.output_disturbance.size() != 0) yi += cfg.output_disturbance(t, i);
      drift[i] += slope[i];
      for (int j = 0; j < nu; ++j)
        if (auto& g = g0[i * nu + j]) yi += g->step(t == 0 ? 0.0 : ua_dev(t - 1, j));
      for (auto& [output, g] : fading)
        if (output == i) yi += g.step(0.0);
      for (int k = 0; k < nx; ++k)
        if (auto& g = gx[i * nx + k]) yi += g->step(t == 0 ? 0.0 : x_dev(t - 1, k));
      y[i] = yi;
    }
    if (plant.outlier_probability > 0.0)
      for (int i = 0; i < ny; ++i) {
        const std::uint64_t bits = outlier_bits();
        if (static_cast<double>(bits >> 11) * 0x1.0p-53 < plant.outlier_probability)
          y[i] += (bits & 1u) ? plant.outlier_size[i] : -plant.outlier_size[i];
      }
    const Eigen::VectorXd& u = pid ? pid->step(y) : mpc->step(y);
    if (cfg.record_qps) {
      res.qp_q.row(t) = mpc->qp_q().transpose();
      res.qp_l.row(t) = mpc->qp_l().transpose();
      res.qp_u.row(t) = mpc->qp_u().transpose();
    }
    res.y.row(t) = y.transpose();
    res.u.row(t) = u.transpose();
    res.setpoint.row(t) = cv_target.transpose();
    for (int j = 0; j < nu; ++j) {
      res.u_actual(t, j) = actuators[j].move(u[j]);
      if (cfg.position_noise.size() != 0) res.u_actual(t, j) += cfg.position_noise(t, j);
      ua_dev(t, j) = res.u_actual(t, j) - u0[j];
    }
  }
  res.failed_solves = mpc ? mpc->failed_solves() : 0;
  return res;
}

}  // namespace mpmpp
