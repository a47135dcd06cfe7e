// Dense dual active-set QP solver (Goldfarb & Idnani, Math. Prog. 27, 1983) for OSQP-form
// problems  min 1/2 x'Px + q'x  s.t.  l <= Ax <= u, with two-sided rows handled natively and
// warm start from the previous active set.
//
// Each row i of A gives up to two one-sided constraints  sigma a_i'x >= sigma b  (sigma = +1 at
// the lower bound b = l_i, sigma = -1 at the upper bound b = u_i); a row is active at most at one
// of them. Rows with l_i == u_i are equalities: they enter the active set first (in the
// factorisation only; x is then computed in closed form) and never leave. An equality whose
// normal is linearly dependent on earlier ones is set aside as redundant and only checked for
// consistency, so duplicated equality rows are not an error.
//
// The dual method starts from a dual-feasible point (the minimiser over the current active set
// with multipliers of inequalities >= 0) and repeatedly adds the most violated constraint,
// dropping active inequalities whose multipliers would turn negative on the way (GI's partial
// steps). A violated constraint whose normal is linearly dependent on the active normals and for
// which no active inequality can be dropped proves primal infeasibility (GI, Step 2c).
#include "mpmpp/qp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "mpmpp/error.hpp"
#include "qp_factorization.hpp"

namespace mpmpp {

const char* to_string(QpStatus s) {
  switch (s) {
    case QpStatus::Solved:
      return "solved";
    case QpStatus::PrimalInfeasible:
      return "primal_infeasible";
    case QpStatus::NonConvex:
      return "non_convex";
    case QpStatus::MaxIterations:
      return "max_iterations";
  }
  return "unknown";
}

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct ActiveConstraint {
  int row;
  int sigma;  // +1: lower bound (or equality), -1: upper bound
};

void check_finite(const Eigen::Ref<const Eigen::MatrixXd>& M, const char* name) {
  if (!M.allFinite()) throw InputError(std::string(name) + " has a NaN or infinite entry");
}

// Throws naming the first entry of `name` where `bad` holds (only called once a check failed).
template <typename Mask>
[[noreturn]] void reject_entry(const Mask& bad, const char* name, const char* what) {
  Eigen::Index i = 0;
  while (i + 1 < bad.size() && !bad[i]) ++i;
  throw InputError(std::string(name) + "[" + std::to_string(i) + "] " + what);
}

}  // namespace

struct QpSolver::Impl {
  int n;
  int m;
  QpSettings settings;
  Eigen::MatrixXd P;
  Eigen::MatrixXd A;   // column-major: A x is a sum of column axpys over the rows (m >> n in MPC)
  Eigen::MatrixXd At;  // A' so that each constraint normal a_i is a contiguous column
  Eigen::VectorXd row_inv_norm;
  Eigen::MatrixXd L_inv_transpose;
  bool positive_definite = false;
  detail::ActiveSetFactorization factorization;

  // The data of the current solve: views of the caller's vectors, valid during solve() only
  // (rebound by load(), no copy), and its bound classification (|bound| >=
  // settings.infinite_bound is infinite).
  using ConstMap = Eigen::Map<const Eigen::VectorXd>;
  ConstMap q{nullptr, 0}, l{nullptr, 0}, u{nullptr, 0};
  Eigen::Array<bool, Eigen::Dynamic, 1> is_equality;
  int num_equalities = 0;
  bool equalities_changed = true;  // is_equality differs from the previous solve's
  bool warm = false;
  // A row i is violated when A_i x < lower_trigger_i or A_i x > upper_trigger_i: its bound
  // moved by the feasibility tolerance, or +-inf while the row is active, an equality or absent.
  Eigen::VectorXd lower_trigger, upper_trigger;

  // Active set in factorisation order (equalities first), multipliers of the one-sided
  // constraints sigma a'x >= sigma b (>= 0 for inequalities), and redundant equality rows.
  std::vector<ActiveConstraint> active;
  int num_active_equalities = 0;
  std::vector<int> redundant_equalities;
  Eigen::VectorXd mult;

  // Workspace, sized once.
  Eigen::VectorXd x, Ax, d, z, r, w, Jq, x_steps;
  double x_P_x = 0.0;
  QpResult result;

  Impl(const Eigen::Ref<const Eigen::MatrixXd>& P_, const Eigen::Ref<const Eigen::MatrixXd>& A_,
       QpSettings s)
      : n(static_cast<int>(P_.rows())),
        m(static_cast<int>(A_.rows())),
        settings(s),
        P(P_),
        A(A_),
        At(A_.transpose()),
        row_inv_norm(m),
        L_inv_transpose(n, n),
        factorization(n),
        is_equality(Eigen::Array<bool, Eigen::Dynamic, 1>::Zero(m)),
        lower_trigger(m),
        upper_trigger(m),
        mult(Eigen::VectorXd::Zero(n)),
        x(n),
        Ax(m),
        d(n),
        z(n),
        r(n),
        w(n),
        Jq(n),
        x_steps(n) {
    active.reserve(n);
    redundant_equalities.reserve(m);
    result.x = Eigen::VectorXd::Zero(n);
    result.y = Eigen::VectorXd::Zero(m);
    for (int i = 0; i < m; ++i) {
      const double norm = At.col(i).norm();
      row_inv_norm[i] = norm > 0.0 ? 1.0 / norm : 1.0;
    }
    Eigen::LLT<Eigen::MatrixXd> llt(P);
    positive_definite = llt.info() == Eigen::Success && n > 0;
    if (positive_definite) {
      // Reject P that is only numerically definite: a pivot of L tiny against P's diagonal
      // means P is semidefinite up to rounding and the GI steps would be meaningless.
      const Eigen::VectorXd pivots = llt.matrixL().toDenseMatrix().diagonal();
      const double scale = P.diagonal().cwiseAbs().maxCoeff();
      positive_definite = pivots.minCoeff() > std::sqrt(settings.definiteness_tol * scale);
    }
    if (positive_definite) {
      L_inv_transpose.setIdentity();
      llt.matrixU().solveInPlace(L_inv_transpose);  // L' X = I  ->  X = L^{-T}
    }
    if (n == 0) positive_definite = true;  // trivial problem, nothing to factorise
  }

  double bound(const ActiveConstraint& c) const { return c.sigma > 0 ? l[c.row] : u[c.row]; }

  void load(const Eigen::Ref<const Eigen::VectorXd>& q_in,
            const Eigen::Ref<const Eigen::VectorXd>& l_in,
            const Eigen::Ref<const Eigen::VectorXd>& u_in) {
    if (q_in.size() != n)
      throw InputError("q has " + std::to_string(q_in.size()) + " entries, expected " +
                       std::to_string(n));
    if (l_in.size() != m)
      throw InputError("l has " + std::to_string(l_in.size()) + " entries, expected " +
                       std::to_string(m));
    if (u_in.size() != m)
      throw InputError("u has " + std::to_string(u_in.size()) + " entries, expected " +
                       std::to_string(m));
    if (!q_in.allFinite()) throw InputError("q has a NaN or infinite entry");
    // Placement new is how an Eigen::Map is pointed at other data.
    new (&q) ConstMap(q_in.data(), n);
    new (&l) ConstMap(l_in.data(), m);
    new (&u) ConstMap(u_in.data(), m);
    const double inf = settings.infinite_bound;
    const double tol = settings.feasibility_tol;
    // One pass over the rows for what every row needs, written so that the compiler vectorises
    // it (flags as selects, no branches; on MPC-sized m the set-up of several Eigen reductions
    // costs more than the work); which entry is bad and why is worked out only on failure.
    // !(u - l >= 0) holds for NaN and for l_i > u_i. The thresholds are arm()'s, except for
    // finite bounds beyond infinite_bound (rare): they stay finite here and are disarmed by
    // most_violated() if such a row is ever picked. Equality rows (usually none in MPC) are
    // classified and disarmed in a second pass, only when there are some now or were before.
    const double* lo = l_in.data();
    const double* up = u_in.data();
    double* lower = lower_trigger.data();
    double* upper = upper_trigger.data();
    double invalid = 0.0, some_equality = 0.0;
    for (int i = 0; i < m; ++i) {
      const bool valid = (up[i] - lo[i] >= 0.0) & (lo[i] < inf) & (up[i] > -inf);
      invalid = valid ? invalid : 1.0;
      some_equality = lo[i] == up[i] ? 1.0 : some_equality;
      lower[i] = lo[i] - tol * (1.0 + std::abs(lo[i]));
      upper[i] = up[i] + tol * (1.0 + std::abs(up[i]));
    }
    if (invalid != 0.0) reject_bounds();
    int equalities = 0;
    bool changed = false;
    if (some_equality != 0.0 || num_equalities > 0) {
      for (int i = 0; i < m; ++i) {
        const bool equality = l[i] == u[i];
        changed |= equality != is_equality[i];
        is_equality[i] = equality;
        if (equality) disarm(i);
        equalities += equality;
      }
    }
    changed |= equalities != num_equalities;
    num_equalities = equalities;
    equalities_changed = changed;
  }

  [[noreturn]] void reject_bounds() const {
    const double inf = settings.infinite_bound;
    const auto L = l.array();
    const auto U = u.array();
    if (L.hasNaN()) reject_entry(L.isNaN(), "l", "is NaN");
    if (U.hasNaN()) reject_entry(U.isNaN(), "u", "is NaN");
    if ((L > U).any()) {
      int i = 0;
      while (!(l[i] > u[i])) ++i;
      throw InputError("l[" + std::to_string(i) + "] > u[" + std::to_string(i) + "]");
    }
    if ((L >= inf).any()) reject_entry(L >= inf, "l", "is +infinite");
    reject_entry(U <= -inf, "u", "is -infinite");
  }

  bool has_lower(int i) const { return l[i] > -settings.infinite_bound; }
  bool has_upper(int i) const { return u[i] < settings.infinite_bound; }

  // Violation thresholds of an inactive row (tolerance relative to 1 + |bound|), as in load().
  void arm(int i) {
    const double tol = settings.feasibility_tol;
    const bool inequality = !is_equality[i];
    lower_trigger[i] =
        inequality && has_lower(i) ? l[i] - tol * (1.0 + std::abs(l[i])) : -kInfinity;
    upper_trigger[i] = inequality && has_upper(i) ? u[i] + tol * (1.0 + std::abs(u[i])) : kInfinity;
  }
  void disarm(int i) {
    lower_trigger[i] = -kInfinity;
    upper_trigger[i] = kInfinity;
  }

  void add_active(int row, int sigma) {
    factorization.add(d, z);
    active.push_back({row, sigma});  // capacity n: the active normals are independent
    disarm(row);
  }

  void drop_active(int position) {
    factorization.drop(position);
    arm(active[position].row);
    active.erase(active.begin() + position);  // no reallocation: erase never grows
    for (int j = position; j < static_cast<int>(active.size()); ++j) mult[j] = mult[j + 1];
  }

  // Cold start: empty active set, then the equality rows (the independent ones).
  void cold_start() {
    factorization.reset(L_inv_transpose);
    active.clear();
    redundant_equalities.clear();
    for (int i = 0; i < m; ++i) {
      if (!is_equality[i]) continue;
      factorization.J_transpose_times(At.col(i), d);
      if (is_dependent()) {
        redundant_equalities.push_back(i);
      } else {
        const int k = factorization.size();
        factorization.J_columns_times(k, d.tail(n - k), z);
        add_active(i, +1);
      }
    }
    num_active_equalities = static_cast<int>(active.size());
  }

  // Warm start: keep the previous active set except inequalities whose bound is now infinite.
  void warm_start() {
    for (const ActiveConstraint& c : active) disarm(c.row);
    for (int j = static_cast<int>(active.size()) - 1; j >= num_active_equalities; --j) {
      const ActiveConstraint& c = active[j];
      if (!(c.sigma > 0 ? has_lower(c.row) : has_upper(c.row))) drop_active(j);
    }
  }

  // Is the normal with d = J'n (in `d`) linearly dependent on the active normals? Its part
  // J2'n orthogonal to them (in the P^{-1} metric) is then ~0 relative to the whole.
  bool is_dependent() const {
    const int k = factorization.size();
    const double free_part = d.tail(n - k).squaredNorm();
    return free_part <= settings.dependency_tol * d.squaredNorm();
  }

  // Minimiser over the active set held as equalities, and its multipliers (closed form):
  // with w = J^{-1} x, R'w1 = b_active, w2 = -J2'q, R mult = w1 + J1'q.
  void solve_on_active_set() {
    const int k = factorization.size();
    if (k == 0) {
      // No active constraint (most MPC samples): x = -J J'q (= -P^{-1} q) and x'Px = |J'q|^2,
      // the steps below without their block set-up.
      factorization.J_transpose_times(q, Jq);
      factorization.J_columns_times(0, Jq, x);
      double squared_norm = 0.0;
      for (int i = 0; i < n; ++i) {
        x[i] = -x[i];
        squared_norm += Jq[i] * Jq[i];
      }
      x_P_x = squared_norm;
      return;
    }
    factorization.J_transpose_times(q, Jq);
    for (int j = 0; j < k; ++j) w[j] = active[j].sigma * bound(active[j]);
    w.tail(n - k) = -Jq.tail(n - k);
    auto w1 = w.head(k);
    factorization.solve_R_transpose(w1);
    factorization.J_columns_times(0, w, x);
    auto mk = mult.head(k);
    mk = w1 + Jq.head(k);
    factorization.solve_R(mk);
    x_P_x = w.squaredNorm();  // x = J w and J'PJ = I
  }

  // Most violated constraint (violation scaled by the row norm), or -1 when all hold; the
  // largest scaled violation (<= 0 when all hold) goes to `max_violation`.
  int most_violated(int& sigma, double& max_violation) {
    max_violation = -kInfinity;
    if (m == 0) return -1;
    // Column-major A: Eigen's gemv runs over the m rows (m >> n in MPC), a few columns at a
    // time. Leading and trailing zeros of x are skipped: MPC puts the slacks last, and they
    // are exactly 0 unless a soft limit binds.
    int first = 0, last = n;
    while (first < last && x[first] == 0.0) ++first;
    while (last > first && x[last - 1] == 0.0) --last;
    if (last > first && m <= detail::kSmallSize) {  // gemv set-up costs more than this
      const int columns = last - first;
      detail::with_static_size(columns, [&](auto size) {
        constexpr int C = decltype(size)::value;
        using Columns = Eigen::Matrix<double, Eigen::Dynamic, C>;
        using Entries = Eigen::Matrix<double, C, 1>;
        Ax.noalias() = Eigen::Map<const Columns>(A.col(first).data(), m, columns)
                           .lazyProduct(Eigen::Map<const Entries>(x.data() + first, columns));
      });
    } else if (last > first)
      Ax.noalias() = A.middleCols(first, last - first) * x.segment(first, last - first);
    else
      Ax.setZero();
    const auto violation =
        (lower_trigger - Ax).cwiseMax(Ax - upper_trigger).cwiseProduct(row_inv_norm);
    for (;;) {
      max_violation = violation.maxCoeff();  // one vectorised pass; the index only when needed
      if (!(max_violation > 0.0)) return -1;
      int p = 0;
      while (violation.coeff(p) != max_violation) ++p;
      sigma = lower_trigger[p] - Ax[p] > 0.0 ? +1 : -1;
      if (sigma > 0 ? has_lower(p) : has_upper(p)) return p;
      // A finite bound beyond infinite_bound (load() left it armed): it is no constraint.
      if (sigma > 0)
        lower_trigger[p] = -kInfinity;
      else
        upper_trigger[p] = kInfinity;
    }
  }

  bool redundant_equalities_hold() const {
    for (int i : redundant_equalities)
      if (std::abs(At.col(i).dot(x) - l[i]) > settings.feasibility_tol * (1.0 + std::abs(l[i])))
        return false;
    return true;
  }

  // Drops active inequalities with negative multipliers until the point is dual feasible, all of
  // them in each round (a closed-form solve costs as much as several drops); needed after a warm
  // start because q, l, u moved, and harmless after the final recompute.
  void restore_dual_feasibility(int& iterations) {
    for (;;) {
      solve_on_active_set();
      bool dropped = false;
      for (int j = static_cast<int>(active.size()) - 1; j >= num_active_equalities; --j) {
        if (mult[j] < -settings.optimality_tol) {
          drop_active(j);
          ++iterations;
          dropped = true;
        }
      }
      if (!dropped) break;
    }
    for (int j = num_active_equalities; j < static_cast<int>(active.size()); ++j)
      mult[j] = std::max(mult[j], 0.0);
  }

  // x_P_x holds x'Px from the last closed-form solve when `exact` (x has not moved since).
  const QpResult& finish(QpStatus status, int iterations, bool exact = false) {
    result.status = status;
    result.iterations = iterations;
    std::copy(x.data(), x.data() + n, result.x.data());  // sizes fixed: no Eigen set-up needed
    std::fill(result.y.data(), result.y.data() + m, 0.0);
    // P x + q = sum_j mult_j sigma_j a_j  and OSQP's  P x + q + A'y = 0  give y = -sigma mult.
    for (int j = 0; j < static_cast<int>(active.size()); ++j)
      result.y[active[j].row] = -active[j].sigma * mult[j];
    if (!exact) {
      w.noalias() = P * x;
      x_P_x = x.dot(w);
    }
    result.objective = 0.5 * x_P_x + q.dot(x);
    return result;
  }

  const QpResult& solve(const Eigen::Ref<const Eigen::VectorXd>& q_in,
                        const Eigen::Ref<const Eigen::VectorXd>& l_in,
                        const Eigen::Ref<const Eigen::VectorXd>& u_in) {
    load(q_in, l_in, u_in);
    if (!positive_definite) {
      x.setZero();
      active.clear();
      warm = false;
      return finish(QpStatus::NonConvex, 0);
    }

    int iterations = 0;
    if (warm && !equalities_changed) {
      warm_start();
    } else {
      cold_start();
    }
    warm = true;
    restore_dual_feasibility(iterations);
    if (!redundant_equalities_hold()) return finish(QpStatus::PrimalInfeasible, iterations);

    bool refined = true;  // x, mult were just computed in closed form
    for (;;) {
      int sigma = 0;
      double max_violation;
      const int p = most_violated(sigma, max_violation);
      if (p < 0) {
        if (refined) return finish(QpStatus::Solved, iterations, /*exact=*/true);
        // The steps accumulate rounding; recompute x on the final active set and re-check.
        x_steps = x;
        const int before = iterations;
        restore_dual_feasibility(iterations);
        refined = true;
        // No drop and x moved by dx: no scaled violation (Lipschitz 1 in |dx|_2) can have
        // crossed zero unless max_violation + |dx|_2 > 0, so the scan just done still holds.
        if (iterations == before && max_violation + (x - x_steps).norm() <= 0.0)
          return finish(QpStatus::Solved, iterations, /*exact=*/true);
        continue;
      }
      refined = false;
      const double b = sigma > 0 ? l[p] : u[p];
      double mult_p = 0.0;  // multiplier of the entering constraint
      // GI Step 2: move towards satisfying constraint p, dropping blocking inequalities.
      for (;;) {
        if (iterations >= settings.max_iterations)
          return finish(QpStatus::MaxIterations, iterations);
        ++iterations;
        const int k = factorization.size();
        factorization.J_transpose_times(At.col(p), d);
        if (sigma < 0) d = -d;
        // r = R^{-1} J1'n: how the active multipliers change per unit of the new one.
        auto rk = r.head(k);
        rk = d.head(k);
        factorization.solve_R(rk);
        // Partial step: the first active inequality whose multiplier reaches zero.
        double t_dual = kInfinity;
        int blocking = -1;
        for (int j = num_active_equalities; j < k; ++j) {
          if (r[j] > 0.0) {
            const double t = mult[j] / r[j];
            if (t < t_dual) {
              t_dual = t;
              blocking = j;
            }
          }
        }
        const bool dependent = is_dependent();
        if (dependent && blocking < 0) return finish(QpStatus::PrimalInfeasible, iterations);
        double t_primal = kInfinity;
        if (!dependent) {
          // Full step: constraint p becomes active. z = J2 J2'n is the primal direction.
          const double curvature = d.tail(n - k).squaredNorm();
          const double gap = sigma * (b - At.col(p).dot(x));
          t_primal = std::max(gap, 0.0) / curvature;
        }
        const double t = std::min(t_dual, t_primal);
        if (!dependent) {
          factorization.J_columns_times(k, d.tail(n - k), z);
          x += t * z;
        }
        mult.head(k) -= t * rk;
        mult_p += t;
        if (t_primal <= t_dual) {
          add_active(p, sigma);
          mult[k] = mult_p;
          break;
        }
        drop_active(blocking);
      }
    }
  }
};

QpSolver::QpSolver(const Eigen::Ref<const Eigen::MatrixXd>& P,
                   const Eigen::Ref<const Eigen::MatrixXd>& A, QpSettings settings) {
  if (P.rows() != P.cols())
    throw InputError("P must be square, got " + std::to_string(P.rows()) + "x" +
                     std::to_string(P.cols()));
  if (A.cols() != P.rows() && !(A.rows() == 0))
    throw InputError("A has " + std::to_string(A.cols()) + " columns, expected " +
                     std::to_string(P.rows()));
  check_finite(P, "P");
  check_finite(A, "A");
  if (!P.isApprox(P.transpose(), 1e-12) && P.size() > 0) throw InputError("P must be symmetric");
  if (settings.max_iterations < 0) throw InputError("max_iterations must be >= 0");
  if (!(settings.feasibility_tol >= 0.0)) throw InputError("feasibility_tol must be >= 0");
  if (!(settings.optimality_tol >= 0.0)) throw InputError("optimality_tol must be >= 0");
  if (!(settings.dependency_tol >= 0.0)) throw InputError("dependency_tol must be >= 0");
  if (!(settings.infinite_bound > 0.0)) throw InputError("infinite_bound must be > 0");
  Eigen::MatrixXd A_checked = A.rows() == 0 ? Eigen::MatrixXd(0, P.rows()) : Eigen::MatrixXd(A);
  impl_ = std::make_unique<Impl>(P, A_checked, settings);
}

QpSolver::~QpSolver() = default;
QpSolver::QpSolver(QpSolver&&) noexcept = default;
QpSolver& QpSolver::operator=(QpSolver&&) noexcept = default;

const QpResult& QpSolver::solve(const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& l,
                                const Eigen::Ref<const Eigen::VectorXd>& u) {
  return impl_->solve(q, l, u);
}

void QpSolver::reset_warm_start() { impl_->warm = false; }
int QpSolver::num_variables() const { return impl_->n; }
int QpSolver::num_constraints() const { return impl_->m; }

QpResult solve_qp(const Eigen::Ref<const Eigen::MatrixXd>& P,
                  const Eigen::Ref<const Eigen::VectorXd>& q,
                  const Eigen::Ref<const Eigen::MatrixXd>& A,
                  const Eigen::Ref<const Eigen::VectorXd>& l,
                  const Eigen::Ref<const Eigen::VectorXd>& u, QpSettings settings) {
  QpSolver solver(P, A, settings);
  return solver.solve(q, l, u);
}

}  // namespace mpmpp
