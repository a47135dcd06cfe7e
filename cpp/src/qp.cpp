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

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "mpmpp/error.hpp"
#include "qp_factorization.hpp"

namespace mpmpp {

const char* to_string(QpStatus s) {
  switch (s) {
    case QpStatus::Solved: return "solved";
    case QpStatus::PrimalInfeasible: return "primal_infeasible";
    case QpStatus::NonConvex: return "non_convex";
    case QpStatus::MaxIterations: return "max_iterations";
  }
  return "unknown";
}

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct ActiveConstraint {
  int row;
  int sigma;  // +1: lower bound (or equality), -1: upper bound
};

void check_finite_or_inf(const Eigen::Ref<const Eigen::VectorXd>& v, const char* name) {
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (std::isnan(v[i])) throw InputError(std::string(name) + "[" + std::to_string(i) + "] is NaN");
}

void check_finite(const Eigen::Ref<const Eigen::MatrixXd>& M, const char* name) {
  if (!M.allFinite()) throw InputError(std::string(name) + " has a NaN or infinite entry");
}

}  // namespace

struct QpSolver::Impl {
  int n;
  int m;
  QpSettings settings;
  Eigen::MatrixXd P;
  Eigen::MatrixXd At;  // A' so that each constraint normal a_i is a contiguous column
  Eigen::VectorXd row_inv_norm;
  Eigen::MatrixXd L_inv_transpose;
  bool positive_definite = false;
  detail::ActiveSetFactorization factorization;

  // Per-solve bound classification (|bound| >= settings.infinite_bound is infinite).
  std::vector<char> has_lower, has_upper, is_equality, previous_is_equality;
  bool warm = false;

  // Active set in factorisation order (equalities first), multipliers of the one-sided
  // constraints sigma a'x >= sigma b (>= 0 for inequalities), and redundant equality rows.
  std::vector<ActiveConstraint> active;
  std::vector<char> is_active;
  int num_active_equalities = 0;
  std::vector<int> redundant_equalities;
  Eigen::VectorXd mult;

  // Workspace, sized once.
  Eigen::VectorXd x, Ax, d, z, r, w, Jq;
  QpResult result;

  Impl(const Eigen::Ref<const Eigen::MatrixXd>& P_, const Eigen::Ref<const Eigen::MatrixXd>& A_,
       QpSettings s)
      : n(static_cast<int>(P_.rows())),
        m(static_cast<int>(A_.rows())),
        settings(s),
        P(P_),
        At(A_.transpose()),
        row_inv_norm(m),
        L_inv_transpose(n, n),
        factorization(n),
        has_lower(m),
        has_upper(m),
        is_equality(m),
        previous_is_equality(m),
        is_active(m, 0),
        mult(Eigen::VectorXd::Zero(n)),
        x(n),
        Ax(m),
        d(n),
        z(n),
        r(n),
        w(n),
        Jq(n) {
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

  double bound(const ActiveConstraint& c, const Eigen::Ref<const Eigen::VectorXd>& l,
               const Eigen::Ref<const Eigen::VectorXd>& u) const {
    return c.sigma > 0 ? l[c.row] : u[c.row];
  }

  void classify_bounds(const Eigen::Ref<const Eigen::VectorXd>& l,
                       const Eigen::Ref<const Eigen::VectorXd>& u) {
    const double inf = settings.infinite_bound;
    for (int i = 0; i < m; ++i) {
      if (l[i] > u[i])
        throw InputError("l[" + std::to_string(i) + "] > u[" + std::to_string(i) + "]");
      has_lower[i] = l[i] > -inf;
      has_upper[i] = u[i] < inf;
      is_equality[i] = has_lower[i] && l[i] == u[i];
    }
  }

  void drop_active(int position) {
    factorization.drop(position);
    is_active[active[position].row] = 0;
    active.erase(active.begin() + position);  // no reallocation: erase never grows
    for (int j = position; j < static_cast<int>(active.size()); ++j) mult[j] = mult[j + 1];
  }

  // Cold start: empty active set, then the equality rows (the independent ones).
  void cold_start() {
    factorization.reset(L_inv_transpose);
    active.clear();
    std::fill(is_active.begin(), is_active.end(), 0);
    redundant_equalities.clear();
    for (int i = 0; i < m; ++i) {
      if (!is_equality[i]) continue;
      d.noalias() = factorization.J().transpose() * At.col(i);
      if (is_dependent()) {
        redundant_equalities.push_back(i);
      } else {
        factorization.add(d);
        active.push_back({i, +1});
        is_active[i] = 1;
      }
    }
    num_active_equalities = static_cast<int>(active.size());
  }

  // Warm start: keep the previous active set except inequalities whose bound is now infinite.
  void warm_start() {
    for (int j = static_cast<int>(active.size()) - 1; j >= num_active_equalities; --j) {
      const ActiveConstraint& c = active[j];
      if (!(c.sigma > 0 ? has_lower[c.row] : has_upper[c.row])) drop_active(j);
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
  void solve_on_active_set(const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& l,
                           const Eigen::Ref<const Eigen::VectorXd>& u) {
    const int k = factorization.size();
    const Eigen::MatrixXd& J = factorization.J();
    Jq.noalias() = J.transpose() * q;
    for (int j = 0; j < k; ++j) w[j] = active[j].sigma * bound(active[j], l, u);
    auto w1 = w.head(k);
    factorization.solve_R_transpose(w1);
    x.noalias() = J.leftCols(k) * w1;
    x.noalias() -= J.rightCols(n - k) * Jq.tail(n - k);
    auto mk = mult.head(k);
    mk = w1 + Jq.head(k);
    factorization.solve_R(mk);
  }

  // Most violated constraint (violation scaled by the row norm), or -1 when all hold to
  // feasibility_tol (relative to 1 + |bound|).
  int most_violated(const Eigen::Ref<const Eigen::VectorXd>& l,
                    const Eigen::Ref<const Eigen::VectorXd>& u, int& sigma) {
    Ax.noalias() = At.transpose() * x;
    int best = -1;
    double best_violation = 0.0;
    for (int i = 0; i < m; ++i) {
      if (is_active[i] || is_equality[i]) continue;
      double v = 0.0;
      int s = 0;
      if (has_lower[i] && l[i] - Ax[i] > settings.feasibility_tol * (1.0 + std::abs(l[i]))) {
        v = l[i] - Ax[i];
        s = +1;
      } else if (has_upper[i] && Ax[i] - u[i] > settings.feasibility_tol * (1.0 + std::abs(u[i]))) {
        v = Ax[i] - u[i];
        s = -1;
      }
      v *= row_inv_norm[i];
      if (s != 0 && v > best_violation) {
        best_violation = v;
        best = i;
        sigma = s;
      }
    }
    return best;
  }

  bool redundant_equalities_hold(const Eigen::Ref<const Eigen::VectorXd>& l) const {
    for (int i : redundant_equalities)
      if (std::abs(At.col(i).dot(x) - l[i]) > settings.feasibility_tol * (1.0 + std::abs(l[i])))
        return false;
    return true;
  }

  // Drops active inequalities with negative multipliers (most negative first) until the point
  // is dual feasible; needed after a warm start because q, l, u moved.
  void restore_dual_feasibility(const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& l,
                                const Eigen::Ref<const Eigen::VectorXd>& u, int& iterations) {
    for (;;) {
      solve_on_active_set(q, l, u);
      int worst = -1;
      double worst_mult = -settings.optimality_tol;
      for (int j = num_active_equalities; j < static_cast<int>(active.size()); ++j) {
        if (mult[j] < worst_mult) {
          worst_mult = mult[j];
          worst = j;
        }
      }
      if (worst < 0) break;
      drop_active(worst);
      ++iterations;
    }
    for (int j = num_active_equalities; j < static_cast<int>(active.size()); ++j)
      mult[j] = std::max(mult[j], 0.0);
  }

  void finish(QpStatus status, int iterations, const Eigen::Ref<const Eigen::VectorXd>& q) {
    result.status = status;
    result.iterations = iterations;
    result.x = x;
    result.y.setZero();
    // P x + q = sum_j mult_j sigma_j a_j  and OSQP's  P x + q + A'y = 0  give y = -sigma mult.
    for (int j = 0; j < static_cast<int>(active.size()); ++j)
      result.y[active[j].row] = -active[j].sigma * mult[j];
    w.noalias() = P * x;
    result.objective = 0.5 * x.dot(w) + q.dot(x);
  }

  const QpResult& solve(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& l,
                        const Eigen::Ref<const Eigen::VectorXd>& u) {
    if (q.size() != n) throw InputError("q has " + std::to_string(q.size()) + " entries, expected " + std::to_string(n));
    if (l.size() != m) throw InputError("l has " + std::to_string(l.size()) + " entries, expected " + std::to_string(m));
    if (u.size() != m) throw InputError("u has " + std::to_string(u.size()) + " entries, expected " + std::to_string(m));
    check_finite(q, "q");
    check_finite_or_inf(l, "l");
    check_finite_or_inf(u, "u");
    classify_bounds(l, u);
    if (!positive_definite) {
      x.setZero();
      active.clear();
      warm = false;
      finish(QpStatus::NonConvex, 0, q);
      return result;
    }

    int iterations = 0;
    if (warm && is_equality == previous_is_equality) {
      warm_start();
    } else {
      cold_start();
    }
    previous_is_equality = is_equality;  // same size: no allocation
    warm = true;
    restore_dual_feasibility(q, l, u, iterations);
    if (!redundant_equalities_hold(l)) {
      finish(QpStatus::PrimalInfeasible, iterations, q);
      return result;
    }

    bool refined = true;  // x, mult were just computed in closed form
    for (;;) {
      int sigma = 0;
      const int p = most_violated(l, u, sigma);
      if (p < 0) {
        if (refined) {
          finish(QpStatus::Solved, iterations, q);
          return result;
        }
        // The steps accumulate rounding; recompute x on the final active set and re-check.
        restore_dual_feasibility(q, l, u, iterations);
        refined = true;
        continue;
      }
      refined = false;
      const double b = sigma > 0 ? l[p] : u[p];
      double mult_p = 0.0;  // multiplier of the entering constraint
      // GI Step 2: move towards satisfying constraint p, dropping blocking inequalities.
      for (;;) {
        if (iterations >= settings.max_iterations) {
          finish(QpStatus::MaxIterations, iterations, q);
          return result;
        }
        ++iterations;
        const int k = factorization.size();
        const Eigen::MatrixXd& J = factorization.J();
        d.noalias() = J.transpose() * At.col(p);
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
        if (dependent && blocking < 0) {
          finish(QpStatus::PrimalInfeasible, iterations, q);
          return result;
        }
        double t_primal = kInfinity;
        if (!dependent) {
          // Full step: constraint p becomes active. z = J2 J2'n is the primal direction.
          const double curvature = d.tail(n - k).squaredNorm();
          const double violation = sigma * (b - At.col(p).dot(x));
          t_primal = std::max(violation, 0.0) / curvature;
        }
        const double t = std::min(t_dual, t_primal);
        if (!dependent) {
          z.noalias() = J.rightCols(n - k) * d.tail(n - k);
          x += t * z;
        }
        mult.head(k) -= t * rk;
        mult_p += t;
        if (t_primal <= t_dual) {
          factorization.add(d);
          active.push_back({p, sigma});
          is_active[p] = 1;
          mult[k] = mult_p;
          break;
        }
        drop_active(blocking);
      }
    }
  }
};

QpSolver::QpSolver(const Eigen::Ref<const Eigen::MatrixXd>& P, const Eigen::Ref<const Eigen::MatrixXd>& A,
                   QpSettings settings) {
  if (P.rows() != P.cols())
    throw InputError("P must be square, got " + std::to_string(P.rows()) + "x" + std::to_string(P.cols()));
  if (A.cols() != P.rows() && !(A.rows() == 0))
    throw InputError("A has " + std::to_string(A.cols()) + " columns, expected " + std::to_string(P.rows()));
  check_finite(P, "P");
  check_finite(A, "A");
  if (!P.isApprox(P.transpose(), 1e-12) && P.size() > 0) throw InputError("P must be symmetric");
  if (settings.max_iterations < 0) throw InputError("max_iterations must be >= 0");
  if (!(settings.feasibility_tol >= 0.0)) throw InputError("feasibility_tol must be >= 0");
  if (!(settings.optimality_tol >= 0.0)) throw InputError("optimality_tol must be >= 0");
  if (!(settings.dependency_tol >= 0.0)) throw InputError("dependency_tol must be >= 0");
  if (!(settings.infinite_bound > 0.0)) throw InputError("infinite_bound must be > 0");
  Eigen::MatrixXd A_checked = A.rows() == 0 ? Eigen::MatrixXd(0, P.rows()) : Eigen::MatrixXd(A);
  impl_ = new Impl(P, A_checked, settings);
}

QpSolver::~QpSolver() { delete impl_; }
QpSolver::QpSolver(QpSolver&& other) noexcept : impl_(std::exchange(other.impl_, nullptr)) {}
QpSolver& QpSolver::operator=(QpSolver&& other) noexcept {
  std::swap(impl_, other.impl_);
  return *this;
}

const QpResult& QpSolver::solve(const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& l,
                                const Eigen::Ref<const Eigen::VectorXd>& u) {
  return impl_->solve(q, l, u);
}

void QpSolver::reset_warm_start() { impl_->warm = false; }
int QpSolver::num_variables() const { return impl_->n; }
int QpSolver::num_constraints() const { return impl_->m; }

QpResult solve_qp(const Eigen::Ref<const Eigen::MatrixXd>& P, const Eigen::Ref<const Eigen::VectorXd>& q,
                  const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::VectorXd>& l,
                  const Eigen::Ref<const Eigen::VectorXd>& u, QpSettings settings) {
  QpSolver solver(P, A, settings);
  return solver.solve(q, l, u);
}

}  // namespace mpmpp
