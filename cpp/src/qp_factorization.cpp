#include "qp_factorization.hpp"

#include <Eigen/Jacobi>
#include <cmath>

namespace mpmpp::detail {

namespace {

// Rotation (c, s) with [c s; -s c] [a; b] = [h; 0]; returns h. (std::hypot's overflow guard
// costs more than the whole rotation here and the entries are far from overflow.)
double givens(double a, double b, double& c, double& s) {
  const double h = std::sqrt(a * a + b * b);
  if (h == 0.0) {
    c = 1.0;
    s = 0.0;
  } else {
    c = a / h;
    s = b / h;
  }
  return h;
}

}  // namespace

ActiveSetFactorization::ActiveSetFactorization(int n)
    : n_(n), J_(Eigen::MatrixXd::Zero(n, n)), R_(Eigen::MatrixXd::Zero(n, n)) {}

void ActiveSetFactorization::reset(const Eigen::MatrixXd& L_inv_transpose) {
  J_ = L_inv_transpose;  // same size: Eigen copies without reallocating
  k_ = 0;
}

void ActiveSetFactorization::add(Eigen::Ref<Eigen::VectorXd> d, Eigen::Ref<Eigen::VectorXd> z) {
  // One Householder reflection H (H d2 = alpha e1) applied to J2 = J(:, k..n-1) maps d = J'n to
  // [d1; alpha; 0], so J' [N n] = [R d1; 0 alpha; 0 0]. (GI use a sequence of Givens rotations;
  // the reflection is the same orthogonal update in one vectorised pass over J2.)
  const int free = n_ - k_;
  auto v = d.tail(free);
  const double norm = v.norm();
  const double alpha = v[0] > 0.0 ? -norm : norm;
  v[0] -= alpha;  // v = d2 - alpha e1, H = I - 2 v v' / v'v
  const double vv = v.squaredNorm();
  if (vv > 0.0) {
    z -= alpha * J_.col(k_);  // J2 v = J2 d2 - alpha J2 e1, without another pass over J2
    const double scale = 2.0 / vv;
    for (int j = 0; j < free; ++j) J_.col(k_ + j) -= (scale * v[j]) * z;
  }
  R_.col(k_).head(k_) = d.head(k_);
  R_(k_, k_) = alpha;
  ++k_;
}

void ActiveSetFactorization::drop(int position) {
  // Removing column `position` of R leaves an upper Hessenberg block; Givens rotations on the
  // rows (j, j+1) restore the triangle, applied to columns (j, j+1) of J to keep J' N = [R; 0].
  for (int j = position; j + 1 < k_; ++j) R_.col(j).head(j + 2) = R_.col(j + 1).head(j + 2);
  for (int j = position; j + 1 < k_; ++j) {
    double c, s;
    R_(j, j) = givens(R_(j, j), R_(j + 1, j), c, s);
    R_(j + 1, j) = 0.0;
    const int rest = k_ - 2 - j;  // columns j+1 .. k-2 of the shifted R
    // JacobiRotation(c, s) on the left and (c, -s) on the right both map (x, y) to
    // (c x + s y, -s x + c y), vectorised by Eigen.
    if (rest > 0)
      R_.middleCols(j + 1, rest).applyOnTheLeft(j, j + 1, Eigen::JacobiRotation<double>(c, s));
    J_.applyOnTheRight(j, j + 1, Eigen::JacobiRotation<double>(c, -s));
  }
  --k_;
}

}  // namespace mpmpp::detail
