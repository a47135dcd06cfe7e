#include "mpmpp/mpc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "mpmpp/detail/incremental_filter.hpp"
#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Fill an empty tuning vector with its default, or check its size and values.
void settle(Eigen::VectorXd& v, int size, double fallback, const char* name, bool allow_inf,
            bool required = false) {
  if (v.size() == 0) {
    if (required) throw InputError(std::string("controller ") + name + " is required");
    v = Eigen::VectorXd::Constant(size, fallback);
    return;
  }
  if (v.size() != size)
    throw InputError(std::string("controller ") + name + " must have " + std::to_string(size) +
                     " entries, got " + std::to_string(v.size()));
  for (Eigen::Index k = 0; k < v.size(); ++k)
    if (std::isnan(v[k]) || (!allow_inf && std::isinf(v[k])))
      throw InputError(std::string("controller ") + name + "[" + std::to_string(k) +
                       "] must be finite");
}

void check_nonnegative(const Eigen::VectorXd& v, const char* name) {
  for (Eigen::Index k = 0; k < v.size(); ++k)
    if (v[k] < 0.0)
      throw InputError(std::string("controller ") + name + "[" + std::to_string(k) +
                       "] must be >= 0");
}

// Leading zero samples of a channel's response: its dead time in samples.
int dead_time(const TransferFunction& g) {
  int lead = 0;
  while (lead < g.num().size() && g.num()[lead] == 0.0) ++lead;
  return g.delay() + lead;
}

// A row of A whose bound moves with the measurements: bound = limit - (u(t-1)[index] or f[index]).
struct MovingBound {
  int row;
  int index;
  bool upper;
  double limit;
};

}  // namespace

struct Mpc::Impl {
  int ny = 0, nu = 0, hp = 0, hc = 0, ndu = 0, nz = 0;
  MpcTuning tuning;
  std::vector<std::optional<detail::IncrementalFilter>> filters;  // [i*nu + j], advanced one sample
  detail::IncrementalFilter scratch;
  // NoiseModel disturbance: H_i^-1 (innovations from Delta v) and H_i (their forecast).
  std::vector<detail::IncrementalFilter> noise_inverse, noise_forward;
  Eigen::VectorXd dist_prev;
  bool started = false;
  Eigen::VectorXd u_lin, u_prev, u_out, mv_range;
  Eigen::VectorXi start;  // d_i
  Eigen::MatrixXd theta, q_from_f, q_from_u, P, A;
  Eigen::VectorXd f, dist, q, l, u, ref, u_gap;
  std::vector<MovingBound> mv_bounds, cv_bounds;
  std::optional<QpSolver> solver;
  QpResult fallback;  // reported before the first solve
  const QpResult* last = nullptr;
  int failed = 0;

  void build_qp();
  void update_reference();
};

Mpc::Mpc(const Model& model, MpcTuning tuning, const Eigen::Ref<const Eigen::VectorXd>& u_initial,
         QpSettings qp_settings)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.ny = model.num_outputs();
  s.nu = model.num_inputs();
  if (s.ny < 1 || s.nu < 1) throw InputError("model needs at least one input and one output");
  if (static_cast<int>(model.process.size()) != s.ny)
    throw InputError("model process must have one row per output");
  for (const auto& row : model.process)
    if (static_cast<int>(row.size()) != s.nu)
      throw InputError("model process must have one entry per input in every row");
  if (tuning.prediction_horizon < 1) throw InputError("controller prediction_horizon must be >= 1");
  if (tuning.control_horizon < 1 || tuning.control_horizon > tuning.prediction_horizon)
    throw InputError("controller control_horizon must be in [1, prediction_horizon]");
  // The condensed QP is dense ((ny Hp) x (nu Hc) dynamic matrix, (nu Hc)^2 Hessian): bounds
  // far beyond MD practice (paper: Hp 40, Hc 4) so a hostile horizon cannot ask for gigabytes.
  if (tuning.prediction_horizon > 10000)
    throw InputError("controller prediction_horizon must be <= 10000");
  if (static_cast<long long>(tuning.control_horizon) * s.nu > 2000)
    throw InputError("controller control_horizon x inputs must be <= 2000 (the QP is dense)");
  if (u_initial.size() != s.nu || !u_initial.allFinite())
    throw InputError("initial inputs must be " + std::to_string(s.nu) + " finite values");
  const int ny = s.ny, nu = s.nu;
  settle(tuning.cv_target, ny, 0.0, "cv_target", false, true);
  if (tuning.mv_target.size() == 0) tuning.mv_target = u_initial;
  settle(tuning.mv_target, nu, 0.0, "mv_target", false);
  settle(tuning.cv_target_weight, ny, 1.0, "cv_target_weight", false);
  settle(tuning.mv_target_weight, nu, 0.0, "mv_target_weight", false);
  settle(tuning.move_weight, nu, 0.0, "move_weight", false, true);
  settle(tuning.deviation_weight, nu, 0.0, "deviation_weight", false);
  settle(tuning.cv_minmax_weight, ny, 1.0, "cv_minmax_weight", false);
  settle(tuning.mv_minmax_weight, nu, 1.0, "mv_minmax_weight", false);
  settle(tuning.mv_min, nu, -kInf, "mv_min", true);
  settle(tuning.mv_max, nu, kInf, "mv_max", true);
  settle(tuning.mv_max_move, nu, kInf, "mv_max_move", true);
  settle(tuning.cv_min, ny, -kInf, "cv_min", true);
  settle(tuning.cv_max, ny, kInf, "cv_max", true);
  settle(tuning.cv_max_move, ny, kInf, "cv_max_move", true);
  settle(tuning.mv_soft_min, nu, -kInf, "mv_soft_min", true);
  settle(tuning.mv_soft_max, nu, kInf, "mv_soft_max", true);
  check_nonnegative(tuning.cv_target_weight, "cv_target_weight");
  check_nonnegative(tuning.mv_target_weight, "mv_target_weight");
  check_nonnegative(tuning.deviation_weight, "deviation_weight");
  check_nonnegative(tuning.cv_minmax_weight, "cv_minmax_weight");
  check_nonnegative(tuning.mv_minmax_weight, "mv_minmax_weight");
  for (int j = 0; j < nu; ++j) {
    const std::string at = "[" + std::to_string(j) + "]";
    if (!(tuning.move_weight[j] > 0.0))
      throw InputError("controller move_weight" + at + " must be > 0");
    if (!(tuning.mv_min[j] <= tuning.mv_max[j]))
      throw InputError("controller mv_min" + at + " must be <= mv_max");
    if (!(tuning.mv_max_move[j] > 0.0))
      throw InputError("controller mv_max_move" + at + " must be > 0");
    if (!(tuning.mv_soft_min[j] <= tuning.mv_soft_max[j]))
      throw InputError("controller mv_soft_min" + at + " must be <= mv_soft_max");
    if ((std::isfinite(tuning.mv_soft_min[j]) || std::isfinite(tuning.mv_soft_max[j])) &&
        !(tuning.mv_minmax_weight[j] > 0.0))
      throw InputError("controller mv_minmax_weight" + at + " must be > 0 with MV soft limits");
    if (u_initial[j] < tuning.mv_min[j] || u_initial[j] > tuning.mv_max[j])
      throw InputError("initial input" + at + " is outside [mv_min, mv_max]");
  }
  for (int i = 0; i < ny; ++i) {
    const std::string at = "[" + std::to_string(i) + "]";
    if (!(tuning.cv_min[i] <= tuning.cv_max[i]))
      throw InputError("controller cv_min" + at + " must be <= cv_max");
    if (!(tuning.cv_max_move[i] > 0.0))
      throw InputError("controller cv_max_move" + at + " must be > 0");
    if ((std::isfinite(tuning.cv_min[i]) || std::isfinite(tuning.cv_max[i]) ||
         std::isfinite(tuning.cv_max_move[i])) &&
        !(tuning.cv_minmax_weight[i] > 0.0))
      throw InputError("controller cv_minmax_weight" + at + " must be > 0 with CV soft limits");
  }
  s.tuning = std::move(tuning);
  s.hp = s.tuning.prediction_horizon;
  s.hc = s.tuning.control_horizon;
  s.ndu = nu * s.hc;
  s.u_lin = u_initial;
  s.u_prev = u_initial;
  s.u_out = u_initial;
  s.mv_range = Eigen::VectorXd::Ones(nu);
  for (int j = 0; j < nu; ++j) {
    const double r = s.tuning.mv_max[j] - s.tuning.mv_min[j];
    if (std::isfinite(r) && r > 0.0) s.mv_range[j] = r;
  }

  // Prediction start d_i and the step responses S_ij.
  s.start = Eigen::VectorXi::Ones(ny);
  s.filters.resize(static_cast<size_t>(ny) * nu);
  for (int i = 0; i < ny; ++i) {
    int d = std::numeric_limits<int>::max();
    for (int j = 0; j < nu; ++j) {
      if (!model.has_channel(i, j)) continue;
      const TransferFunction& g = *model.process[i][j];
      const std::string what = "model channel " + model.outputs[i] + " <- " + model.inputs[j];
      s.filters[i * nu + j].emplace(detail::advanced_one_sample(g, what));
      if (!g.is_zero()) d = std::min(d, dead_time(g));
    }
    if (d != std::numeric_limits<int>::max()) s.start[i] = d;
  }
  const int horizon_end = s.start.maxCoeff() + s.hp;
  s.theta = Eigen::MatrixXd::Zero(ny * s.hp, s.ndu);
  for (int i = 0; i < ny; ++i)
    for (int j = 0; j < nu; ++j) {
      if (!model.has_channel(i, j)) continue;
      const Eigen::VectorXd step = model.process[i][j]->step(horizon_end);
      for (int k = 0; k < s.hp; ++k)
        for (int m = 0; m < s.hc; ++m) {
          const int n = s.start[i] + k - m;
          if (n >= 0) s.theta(i * s.hp + k, m * nu + j) = step[n];
        }
    }
  if (s.tuning.disturbance == DisturbanceModel::NoiseModel) {
    if (static_cast<int>(model.noise.size()) != ny)
      throw InputError(
          "model noise must have one model per output for the noise-model disturbance");
    for (int i = 0; i < ny; ++i) {
      const TransferFunction& h = model.noise[i];
      if (h.delay() != 0 || h.num()[0] != 1.0 || !h.is_minimum_phase())
        throw InputError("model noise of " + model.outputs[i] +
                         " must be monic and inversely stable for the noise-model disturbance");
      s.noise_inverse.emplace_back(h.inverse());
      s.noise_forward.emplace_back(h);
    }
  }
  s.build_qp();
  s.solver.emplace(s.P, s.A, qp_settings);
  s.f = Eigen::VectorXd::Zero(ny * s.hp);
  s.dist = Eigen::VectorXd::Zero(ny);
  s.dist_prev = Eigen::VectorXd::Zero(ny);
  s.ref.resize(ny * s.hp);
  s.u_gap.resize(s.ndu);
  s.update_reference();
  s.fallback.x = Eigen::VectorXd::Zero(s.nz);
  s.fallback.y = Eigen::VectorXd::Zero(s.A.rows());
}

void Mpc::Impl::build_qp() {
  const MpcTuning& t = tuning;
  // Cumulative-sum map: u(t+m) - u(t-1) = C du.
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(ndu, ndu);
  for (int m = 0; m < hc; ++m)
    for (int l = 0; l <= m; ++l) C.block(m * nu, l * nu, nu, nu).setIdentity();
  Eigen::VectorXd wy(ny * hp), wmove(ndu), wtarget(ndu), wdev(ndu);
  for (int i = 0; i < ny; ++i) wy.segment(i * hp, hp).setConstant(t.cv_target_weight[i]);
  for (int m = 0; m < hc; ++m)
    for (int j = 0; j < nu; ++j) {
      wmove[m * nu + j] = t.move_weight[j];
      wtarget[m * nu + j] = t.mv_target_weight[j] / (mv_range[j] * mv_range[j]);
      wdev[m * nu + j] = t.deviation_weight[j];
    }
  // Slacks: one per soft-limited MV, CV (min/max) and CV (movement).
  std::vector<int> mv_soft, cv_soft, cv_move;
  for (int j = 0; j < nu; ++j)
    if (std::isfinite(t.mv_soft_min[j]) || std::isfinite(t.mv_soft_max[j])) mv_soft.push_back(j);
  for (int i = 0; i < ny; ++i) {
    if (std::isfinite(t.cv_min[i]) || std::isfinite(t.cv_max[i])) cv_soft.push_back(i);
    if (std::isfinite(t.cv_max_move[i])) cv_move.push_back(i);
  }
  const int ns = static_cast<int>(mv_soft.size() + cv_soft.size() + cv_move.size());
  nz = ndu + ns;

  P = Eigen::MatrixXd::Zero(nz, nz);
  P.topLeftCorner(ndu, ndu) = 2.0 * (theta.transpose() * wy.asDiagonal() * theta);
  P.topLeftCorner(ndu, ndu).diagonal() += 2.0 * wmove;
  P.topLeftCorner(ndu, ndu) += 2.0 * C.transpose() * (wtarget + wdev).asDiagonal() * C;
  q_from_f = 2.0 * theta.transpose() *
             wy.asDiagonal();  // q_du = q_from_f (f - r) + q_from_u (u(t-1) - u_target)
  q_from_u = 2.0 * C.transpose() * wtarget.asDiagonal();

  // Rows of A, counted first, then filled.
  std::vector<Eigen::RowVectorXd> rows;
  std::vector<double> lo, hi;
  mv_bounds.clear();
  cv_bounds.clear();
  auto add_row = [&](const Eigen::RowVectorXd& r, double l_, double u_) {
    rows.push_back(r);
    lo.push_back(l_);
    hi.push_back(u_);
    return static_cast<int>(rows.size()) - 1;
  };
  auto unit = [&](int col) {
    Eigen::RowVectorXd r = Eigen::RowVectorXd::Zero(nz);
    r[col] = 1.0;
    return r;
  };
  // Hard MV bounds over the control horizon (bounds move with u(t-1)).
  for (int m = 0; m < hc; ++m)
    for (int j = 0; j < nu; ++j) {
      if (!std::isfinite(t.mv_min[j]) && !std::isfinite(t.mv_max[j])) continue;
      Eigen::RowVectorXd r = Eigen::RowVectorXd::Zero(nz);
      r.head(ndu) = C.row(m * nu + j);
      const int row = add_row(r, -kInf, kInf);
      if (std::isfinite(t.mv_min[j])) mv_bounds.push_back({row, j, false, t.mv_min[j]});
      if (std::isfinite(t.mv_max[j])) mv_bounds.push_back({row, j, true, t.mv_max[j]});
    }
  // Hard move limits (clipped after the solve instead with clip_moves).
  for (int m = 0; m < hc && !t.clip_moves; ++m)
    for (int j = 0; j < nu; ++j)
      if (std::isfinite(t.mv_max_move[j]))
        add_row(unit(m * nu + j), -t.mv_max_move[j], t.mv_max_move[j]);
  int slack = ndu;
  // Soft MV limits: C du - s <= max - u(t-1), C du + s >= min - u(t-1).
  for (int j : mv_soft) {
    for (int m = 0; m < hc; ++m) {
      Eigen::RowVectorXd r = Eigen::RowVectorXd::Zero(nz);
      r.head(ndu) = C.row(m * nu + j);
      if (std::isfinite(t.mv_soft_max[j])) {
        r[slack] = -1.0;
        mv_bounds.push_back({add_row(r, -kInf, kInf), j, true, t.mv_soft_max[j]});
      }
      if (std::isfinite(t.mv_soft_min[j])) {
        r[slack] = 1.0;
        mv_bounds.push_back({add_row(r, -kInf, kInf), j, false, t.mv_soft_min[j]});
      }
    }
    P(slack, slack) = 2.0 * t.mv_minmax_weight[j];
    ++slack;
  }
  // Soft CV limits on the forecast: Theta du - s <= max - f, Theta du + s >= min - f.
  for (int i : cv_soft) {
    for (int k = 0; k < hp; ++k) {
      Eigen::RowVectorXd r = Eigen::RowVectorXd::Zero(nz);
      r.head(ndu) = theta.row(i * hp + k);
      if (std::isfinite(t.cv_max[i])) {
        r[slack] = -1.0;
        cv_bounds.push_back({add_row(r, -kInf, kInf), i * hp + k, true, t.cv_max[i]});
      }
      if (std::isfinite(t.cv_min[i])) {
        r[slack] = 1.0;
        cv_bounds.push_back({add_row(r, -kInf, kInf), i * hp + k, false, t.cv_min[i]});
      }
    }
    P(slack, slack) = 2.0 * t.cv_minmax_weight[i];
    ++slack;
  }
  // Soft CV movement: per-sample change of the forced forecast, |D du| <= limit + s.
  for (int i : cv_move) {
    for (int k = 0; k < hp; ++k) {
      Eigen::RowVectorXd r = Eigen::RowVectorXd::Zero(nz);
      r.head(ndu) = theta.row(i * hp + k);
      if (k > 0) r.head(ndu) -= theta.row(i * hp + k - 1);
      r[slack] = -1.0;
      add_row(r, -kInf, t.cv_max_move[i]);
      r[slack] = 1.0;
      add_row(r, -t.cv_max_move[i], kInf);
    }
    P(slack, slack) = 2.0 * t.cv_minmax_weight[i];
    ++slack;
  }
  for (int k = ndu; k < nz; ++k) add_row(unit(k), 0.0, kInf);

  A.resize(static_cast<Eigen::Index>(rows.size()), nz);
  for (size_t r = 0; r < rows.size(); ++r) A.row(static_cast<Eigen::Index>(r)) = rows[r];
  l = Eigen::Map<Eigen::VectorXd>(lo.data(), static_cast<Eigen::Index>(lo.size()));
  u = Eigen::Map<Eigen::VectorXd>(hi.data(), static_cast<Eigen::Index>(hi.size()));
  q = Eigen::VectorXd::Zero(nz);
}

void Mpc::Impl::update_reference() {
  for (int i = 0; i < ny; ++i) ref.segment(i * hp, hp).setConstant(tuning.cv_target[i]);
}

Mpc::~Mpc() = default;
Mpc::Mpc(Mpc&&) noexcept = default;
Mpc& Mpc::operator=(Mpc&&) noexcept = default;

const Eigen::VectorXd& Mpc::step(const Eigen::Ref<const Eigen::VectorXd>& y) {
  Impl& s = *impl_;
  if (y.size() != s.ny)
    throw InputError("measured outputs must have " + std::to_string(s.ny) + " entries");
  const int nu = s.nu, hp = s.hp;
  // Nominal model output y_model(t) from u(t-1); disturbance estimate held over the horizon.
  for (int i = 0; i < s.ny; ++i) {
    double ym = 0.0;
    for (int j = 0; j < nu; ++j)
      if (auto& g = s.filters[i * nu + j]) ym += g->step(s.u_prev[j] - s.u_lin[j]);
    s.dist[i] = y[i] - ym;
  }
  const bool noise_model = s.tuning.disturbance == DisturbanceModel::NoiseModel;
  if (noise_model && !s.started) s.dist_prev = s.dist;  // Delta v(0) = 0: no history yet
  s.started = true;
  // Free response: each channel's filter copied and run with u held at u(t-1).
  for (int i = 0; i < s.ny; ++i) {
    auto fi = s.f.segment(i * hp, hp);
    fi.setConstant(s.dist[i]);
    const int d = s.start[i];
    if (noise_model) {
      const double innovation = s.noise_inverse[i].step(s.dist[i] - s.dist_prev[i]);
      s.noise_forward[i].step(innovation);
      s.scratch = s.noise_forward[i];
      double ahead = 0.0;  // sum of the forecast Delta v up to t + tau (future e = 0)
      for (int tau = 1; tau < d + hp; ++tau) {
        ahead += s.scratch.step(0.0);
        if (tau >= d) fi[tau - d] += ahead;
      }
      s.dist_prev[i] = s.dist[i];
    }
    for (int j = 0; j < nu; ++j) {
      const auto& g = s.filters[i * nu + j];
      if (!g) continue;
      s.scratch = *g;
      const double x = s.u_prev[j] - s.u_lin[j];
      for (int tau = 1; tau < d + hp; ++tau) {
        const double v = s.scratch.step(x);
        if (tau >= d) fi[tau - d] += v;
      }
    }
  }
  for (int m = 0; m < s.hc; ++m) s.u_gap.segment(m * nu, nu) = s.u_prev - s.tuning.mv_target;
  s.q.head(s.ndu).noalias() = s.q_from_f * (s.f - s.ref);
  s.q.head(s.ndu).noalias() += s.q_from_u * s.u_gap;
  for (const MovingBound& b : s.mv_bounds)
    (b.upper ? s.u[b.row] : s.l[b.row]) = b.limit - s.u_prev[b.index];
  for (const MovingBound& b : s.cv_bounds)
    (b.upper ? s.u[b.row] : s.l[b.row]) = b.limit - s.f[b.index];

  const QpResult& r = s.solver->solve(s.q, s.l, s.u);
  s.last = &r;
  Eigen::VectorXd::ConstSegmentReturnType du = r.x.head(nu);
  if (r.status == QpStatus::Solved && !s.tuning.clip_moves) {
    s.u_out = s.u_prev + du;
  } else {
    if (r.status != QpStatus::Solved) ++s.failed;
    for (int j = 0; j < nu; ++j) {
      const double step = std::clamp(du[j], -s.tuning.mv_max_move[j], s.tuning.mv_max_move[j]);
      s.u_out[j] = std::clamp(s.u_prev[j] + step, s.tuning.mv_min[j], s.tuning.mv_max[j]);
    }
  }
  s.u_prev = s.u_out;
  return s.u_out;
}

void Mpc::set_cv_target(int output, double value) {
  if (output < 0 || output >= impl_->ny) throw InputError("cv target output index out of range");
  if (!std::isfinite(value)) throw InputError("cv target must be finite");
  impl_->tuning.cv_target[output] = value;
  impl_->update_reference();
}

void Mpc::set_mv_target(int input, double value) {
  if (input < 0 || input >= impl_->nu) throw InputError("mv target input index out of range");
  if (!std::isfinite(value)) throw InputError("mv target must be finite");
  impl_->tuning.mv_target[input] = value;
}

const MpcTuning& Mpc::tuning() const { return impl_->tuning; }
const Eigen::VectorXd& Mpc::u() const { return impl_->u_out; }
const Eigen::VectorXi& Mpc::prediction_start() const { return impl_->start; }
const Eigen::MatrixXd& Mpc::qp_P() const { return impl_->P; }
const Eigen::MatrixXd& Mpc::qp_A() const { return impl_->A; }
const Eigen::VectorXd& Mpc::qp_q() const { return impl_->q; }
const Eigen::VectorXd& Mpc::qp_l() const { return impl_->l; }
const Eigen::VectorXd& Mpc::qp_u() const { return impl_->u; }
const QpResult& Mpc::last_result() const { return impl_->last ? *impl_->last : impl_->fallback; }
const Eigen::MatrixXd& Mpc::dynamic_matrix() const { return impl_->theta; }
const Eigen::VectorXd& Mpc::free_response() const { return impl_->f; }
const Eigen::VectorXd& Mpc::disturbance_estimate() const { return impl_->dist; }
int Mpc::num_variables() const { return impl_->nz; }
int Mpc::failed_solves() const { return impl_->failed; }

}  // namespace mpmpp
