#pragma once
// Dense convex QP in OSQP's form:
//   minimise 1/2 x'Px + q'x   subject to   l <= A x <= u
// A row with l == u is an equality; +-infinity bounds are allowed.
// Duals y follow OSQP's sign convention: y_i > 0 when the upper bound of row i
// is active, y_i < 0 when the lower bound is active, and P x + q + A'y = 0.
#include <Eigen/Dense>
#include <memory>

namespace mpmpp {

enum class QpStatus {
  Solved,
  PrimalInfeasible,
  NonConvex,      // P not positive definite (after any documented regularisation)
  MaxIterations,  // best iterate returned: the last one, since the dual objective only grows
};

const char* to_string(QpStatus s);

struct QpSettings {
  int max_iterations = 1000;
  double feasibility_tol = 1e-9;  // primal constraint violation accepted as feasible
  double optimality_tol = 1e-9;   // dual (multiplier sign) tolerance
  // A constraint normal n counts as linearly dependent on the active ones when the part of it
  // that the active set leaves free is this small: |J2'n|^2 <= dependency_tol |J'n|^2 (J'PJ = I),
  // i.e. the sine of its angle to their span in the P^{-1} metric is below sqrt(dependency_tol).
  double dependency_tol = 1e-14;
  // P counts as positive definite when every Cholesky pivot L_ii^2 > definiteness_tol max|P_ii|.
  double definiteness_tol = 1e-14;
  // Bounds with |l_i| or |u_i| >= infinite_bound are infinite (Maros-Meszaros files use 1e20).
  double infinite_bound = 1e20;
};

struct QpResult {
  Eigen::VectorXd x;
  Eigen::VectorXd y;
  QpStatus status = QpStatus::MaxIterations;
  int iterations = 0;
  double objective = 0.0;
};

// Algorithm: the dual active-set method of Goldfarb & Idnani (1983), see cpp/src/qp.cpp and
// docs/qp.md. A warm solve (same P, A) does not allocate.
// P must be positive definite (status NonConvex otherwise; no regularisation is attempted).
// Inputs are checked: wrong sizes, NaN, or l_i > u_i throw InputError.
//
// A solver for a sequence of QPs with fixed P and A whose q, l, u change (MPC):
// the factorisation of P is kept and each solve starts from the previous active set.
class QpSolver {
 public:
  QpSolver(const Eigen::Ref<const Eigen::MatrixXd>& P, const Eigen::Ref<const Eigen::MatrixXd>& A,
           QpSettings settings = {});
  ~QpSolver();
  QpSolver(QpSolver&&) noexcept;
  QpSolver& operator=(QpSolver&&) noexcept;

  const QpResult& solve(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& l,
                        const Eigen::Ref<const Eigen::VectorXd>& u);
  void reset_warm_start();
  int num_variables() const;
  int num_constraints() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One-shot convenience: builds a QpSolver and solves once.
QpResult solve_qp(const Eigen::Ref<const Eigen::MatrixXd>& P,
                  const Eigen::Ref<const Eigen::VectorXd>& q,
                  const Eigen::Ref<const Eigen::MatrixXd>& A,
                  const Eigen::Ref<const Eigen::VectorXd>& l,
                  const Eigen::Ref<const Eigen::VectorXd>& u, QpSettings settings = {});

}  // namespace mpmpp
