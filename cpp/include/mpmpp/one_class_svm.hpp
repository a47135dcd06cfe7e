#pragma once
// nu-one-class support vector machine with the Gaussian kernel (paper Section 4.1).
//
// Paper form (eqs 16-20), l training points x_i, kernel k(x, y) = exp(-||x - y||^2 / c) (eq 15):
//   min_a 1/2 sum_ij a_i a_j k(x_i, x_j)   s.t. 0 <= a_i <= 1/(nu l),  sum_i a_i = 1      (18-19)
//   h(x) = sum_i a_i k(x_i, x) - b                                                          (20)
// Solver form (libsvm / scikit-learn scaling), alpha_i = nu l * a_i:
//   min_alpha 1/2 alpha' K alpha   s.t. 0 <= alpha_i <= 1,  sum_i alpha_i = nu l
//   f(x) = sum_i alpha_i k(x_i, x) - rho,      rho = nu l * b,  so  f(x) = nu l * h(x).
// The solver works in the libsvm scaling because it keeps the box [0, 1] independent of l
// and reproduces scikit-learn's OneClassSVM (gamma = 1/c) to round-off: same initial point,
// same second-order working-set selection (Fan, Chen & Lin, JMLR 2005), same shrinking
// and stopping rule, kernel columns cached in single precision as libsvm does.
// The sign of f and h is the same: positive = inside the "normal" region.
#include <Eigen/Dense>
#include <cstdint>

#include "mpmpp/eigen_types.hpp"

namespace mpmpp {

struct OneClassSvmOptions {
  double nu = 0.5;             // (0, 1]: upper bound on the outlier fraction, lower bound on SVs
  double kernel_scale = 1.0;   // c in eq (15); scikit-learn's gamma = 1 / c
  double tol = 1e-3;           // stop when the maximal KKT violation m(alpha) - M(alpha) < tol
  double cache_mb = 200.0;     // kernel-column cache budget (single-precision columns, LRU)
  bool shrinking = true;       // libsvm shrinking heuristic
  std::int64_t max_iter = -1;  // SMO iteration limit; -1 = none
};

struct OneClassSvmModel {
  RowMatrixXd support_vectors;  // n_sv x m, in training order
  Eigen::VectorXi support;      // row indices of the support vectors in the training set
  Eigen::VectorXd dual_coef;    // alpha_i (libsvm scaling) of the support vectors, in (0, 1]
  double rho = 0.0;             // libsvm offset: f(x) = dual_coef' k(sv, x) - rho
  double kernel_scale = 1.0;    // c
  double nu = 0.5;
  int n_train = 0;  // l
  std::int64_t iterations = 0;
  bool converged = true;   // false when max_iter stopped the solver
  double objective = 0.0;  // 1/2 alpha' K alpha at the solution (libsvm scaling)

  // sum_i alpha_i k(sv_i, x) for each row x of X (scikit-learn's score_samples).
  Eigen::VectorXd score_samples(const Eigen::Ref<const RowMatrixXd>& X) const;
  // f(x) = score_samples(x) - rho (scikit-learn's decision_function).
  Eigen::VectorXd decision_function(const Eigen::Ref<const RowMatrixXd>& X) const;
  // Paper scaling of eq (20): a_i = alpha_i / (nu l), b = rho / (nu l), h(x) = f(x) / (nu l).
  double paper_scale() const { return nu * n_train; }
};

// Solve the dual (18-19) by SMO. Throws InputError for an empty or non-finite X, nu outside
// (0, 1], c <= 0, tol <= 0, cache_mb <= 0 or max_iter == 0 / < -1. Documented degenerate
// results: l = 1 or all points identical give f = 0 at the training points (nothing strictly
// inside), as libsvm does; nu = 1 (every alpha at the bound, rho not unique) takes the smallest
// optimal rho = max_i sum_j alpha_j k(x_j, x_i), where libsvm returns +inf.
OneClassSvmModel fit_one_class_svm(const Eigen::Ref<const RowMatrixXd>& X,
                                   const OneClassSvmOptions& options = {});

// sum_i coef_i exp(-||sv_i - x||^2 / c) for each row x of X, computed in blocks as
// ||x||^2 + ||sv||^2 - 2 x.sv with Eigen matrix products (then exp). n_threads <= 0 uses
// hardware concurrency (at most 8 threads); 1 runs serially.
Eigen::VectorXd gaussian_kernel_expansion(const Eigen::Ref<const RowMatrixXd>& support_vectors,
                                          const Eigen::Ref<const Eigen::VectorXd>& coef,
                                          double kernel_scale,
                                          const Eigen::Ref<const RowMatrixXd>& X,
                                          int n_threads = 1);

}  // namespace mpmpp
