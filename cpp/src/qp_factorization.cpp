#include "qp_factorization.hpp"

#include <cmath>

namespace mpmpp::detail {

namespace {

// Rotation (c, s) with [c s; -s c] [a; b] = [h; 0]; returns h.
double givens(double a, double b, double& c, double& s) {
  const double h = std::hypot(a, b);
  if (h == 0.0) {
    c = 1.0;
    s = 0.0;
  } else {
    c = a / h;
    s = b / h;
  }
  return h;
}

// Columns (x, y) <- (c x + s y, -s x + c y): keeps J' P J = I since the rotation is orthogonal.
template <typename X, typename Y>
void rotate(X&& x, Y&& y, double c, double s) {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double xi = x[i];
    const double yi = y[i];
    x[i] = c * xi + s * yi;
    y[i] = -s * xi + c * yi;
  }
}

}  // namespace

ActiveSetFactorization::ActiveSetFactorization(int n)
    : n_(n), J_(Eigen::MatrixXd::Zero(n, n)), R_(Eigen::MatrixXd::Zero(n, n)) {}

void ActiveSetFactorization::reset(const Eigen::MatrixXd& L_inv_transpose) {
  J_ = L_inv_transpose;  // same size: Eigen copies without reallocating
  k_ = 0;
}

void ActiveSetFactorization::add(Eigen::Ref<Eigen::VectorXd> d) {
  // Zero d(k+1..n-1) from the bottom up into d(k), rotating the matching columns of J so that
  // d stays J' n; afterwards J' [N n] = [R d(0..k); 0].
  for (int j = n_ - 1; j > k_; --j) {
    double c, s;
    d[j - 1] = givens(d[j - 1], d[j], c, s);
    d[j] = 0.0;
    rotate(J_.col(j - 1), J_.col(j), c, s);
  }
  R_.col(k_).head(k_ + 1) = d.head(k_ + 1);
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
    if (rest > 0) rotate(R_.row(j).segment(j + 1, rest), R_.row(j + 1).segment(j + 1, rest), c, s);
    rotate(J_.col(j), J_.col(j + 1), c, s);
  }
  --k_;
}

}  // namespace mpmpp::detail
