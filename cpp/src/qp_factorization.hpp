#pragma once
// Internal to the QP solver: the Goldfarb-Idnani factorisation of the active set.
//
// With P = L L' (Cholesky, once per solver) and N = [n_1 ... n_k] the normals of the active
// constraints (n_j'x >= b_j), Goldfarb & Idnani (Math. Prog. 27, 1983) keep
//     J = L^{-T} Q   (n x n, so J' P J = I)   and   J' N = [R; 0]   (R k x k upper triangular).
// J1 (first k columns) spans the active normals in the P^{-1} metric, J2 (the rest) the
// directions that keep every active constraint fixed. Adding or dropping one constraint is an
// O(n^2) update (a Householder reflection to add, Givens rotations to drop); nothing here
// allocates after construction.
#include <Eigen/Dense>
#include <type_traits>

namespace mpmpp::detail {

// Eigen's dynamic-size kernels (blocked or coefficient-wise) cost more to set up than the
// whole product for the small matrices of MPC problems (n up to about a dozen); up to this size
// the products are plain loops over contiguous columns. (Eigen's fixed-size kernels, dispatched
// on n, were no faster at n = 4 and slower at n = 9: callgrind on the paper's QPs.)
constexpr int kSmallSize = 12;

// with_static_size(size, kernel) calls kernel(std::integral_constant<int, N>()) with N = size
// for 1 <= size <= kSmallSize (a jump table), N = Eigen::Dynamic otherwise: for products whose
// inner dimension is small but whose other one is not, where a compile-time inner size lets
// Eigen unroll the inner loop.
template <typename Kernel>
void with_static_size(int size, Kernel&& kernel) {
  using std::integral_constant;
  switch (size) {
    case 1:
      return kernel(integral_constant<int, 1>());
    case 2:
      return kernel(integral_constant<int, 2>());
    case 3:
      return kernel(integral_constant<int, 3>());
    case 4:
      return kernel(integral_constant<int, 4>());
    case 5:
      return kernel(integral_constant<int, 5>());
    case 6:
      return kernel(integral_constant<int, 6>());
    case 7:
      return kernel(integral_constant<int, 7>());
    case 8:
      return kernel(integral_constant<int, 8>());
    case 9:
      return kernel(integral_constant<int, 9>());
    case 10:
      return kernel(integral_constant<int, 10>());
    case 11:
      return kernel(integral_constant<int, 11>());
    case 12:
      return kernel(integral_constant<int, 12>());
    default:
      return kernel(integral_constant<int, Eigen::Dynamic>());
  }
}
static_assert(kSmallSize == 12, "with_static_size has one case per size up to kSmallSize");

class ActiveSetFactorization {
 public:
  explicit ActiveSetFactorization(int n);

  // Empty active set: J = L^{-T}.
  void reset(const Eigen::MatrixXd& L_inv_transpose);

  int size() const { return k_; }

  // The products and solves of the method. The triangular solves are written out (column axpys
  // and dot products): k is small and Eigen's blocked triangular kernels cost more to set up.
  // out = J' a.
  void J_transpose_times(const Eigen::Ref<const Eigen::VectorXd>& a,
                         Eigen::Ref<Eigen::VectorXd> out) const {
    if (n_ > kSmallSize) {
      out.noalias() = J_.transpose() * a;
      return;
    }
    for (int c = 0; c < n_; ++c) {
      const double* J_c = J_.col(c).data();
      double sum = 0.0;
      for (int r = 0; r < n_; ++r) sum += J_c[r] * a[r];
      out[c] = sum;
    }
  }
  // out = J(:, first .. first+c.size()-1) c (out = 0 when c is empty).
  void J_columns_times(int first, const Eigen::Ref<const Eigen::VectorXd>& c,
                       Eigen::Ref<Eigen::VectorXd> out) const {
    if (n_ > kSmallSize) {
      out.noalias() = J_.middleCols(first, c.size()) * c;
      return;
    }
    for (int r = 0; r < n_; ++r) out[r] = 0.0;
    for (int j = 0; j < c.size(); ++j) {
      const double* J_j = J_.col(first + j).data();
      const double c_j = c[j];
      for (int r = 0; r < n_; ++r) out[r] += J_j[r] * c_j;
    }
  }
  // v <- R^{-1} v (back substitution by columns of R), v of length size().
  template <typename V>
  void solve_R(V&& v) const {
    for (int j = k_ - 1; j >= 0; --j) {
      v[j] /= R_(j, j);
      v.head(j) -= v[j] * R_.col(j).head(j);
    }
  }
  // v <- R^{-T} v (forward substitution, dot products with columns of R).
  template <typename V>
  void solve_R_transpose(V&& v) const {
    for (int i = 0; i < k_; ++i) v[i] = (v[i] - R_.col(i).head(i).dot(v.head(i))) / R_(i, i);
  }

  // Appends a constraint whose normal n gives d = J' n and z = J2 J2' n (computed with the
  // current J; z is GI's primal step direction). Both are overwritten. The caller has checked
  // that d.tail(n - size()) is not ~0.
  void add(Eigen::Ref<Eigen::VectorXd> d, Eigen::Ref<Eigen::VectorXd> z);

  // Removes the constraint at position `position` (0-based, in order of addition).
  void drop(int position);

 private:
  int n_;
  int k_ = 0;
  Eigen::MatrixXd J_;
  Eigen::MatrixXd R_;
};

}  // namespace mpmpp::detail
