#pragma once
// Internal to the QP solver: the Goldfarb-Idnani factorisation of the active set.
//
// With P = L L' (Cholesky, once per solver) and N = [n_1 ... n_k] the normals of the active
// constraints (n_j'x >= b_j), Goldfarb & Idnani (Math. Prog. 27, 1983) keep
//     J = L^{-T} Q   (n x n, so J' P J = I)   and   J' N = [R; 0]   (R k x k upper triangular).
// J1 (first k columns) spans the active normals in the P^{-1} metric, J2 (the rest) the
// directions that keep every active constraint fixed. Adding or dropping one constraint is an
// O(n^2) sequence of Givens rotations; nothing here allocates after construction.
#include <Eigen/Dense>

namespace mpmpp::detail {

class ActiveSetFactorization {
 public:
  explicit ActiveSetFactorization(int n);

  // Empty active set: J = L^{-T}.
  void reset(const Eigen::MatrixXd& L_inv_transpose);

  int size() const { return k_; }
  const Eigen::MatrixXd& J() const { return J_; }
  // v <- R^{-1} v and v <- R^{-T} v for v of length size(), in place.
  template <typename V>
  void solve_R(V&& v) const {
    R_.topLeftCorner(k_, k_).triangularView<Eigen::Upper>().solveInPlace(v);
  }
  template <typename V>
  void solve_R_transpose(V&& v) const {
    R_.topLeftCorner(k_, k_).transpose().triangularView<Eigen::Lower>().solveInPlace(v);
  }

  // Appends a constraint whose normal n gives d = J' n (computed with the current J).
  // d is overwritten (rotated). The caller has checked that d.tail(n - size()) is not ~0.
  void add(Eigen::Ref<Eigen::VectorXd> d);

  // Removes the constraint at position `position` (0-based, in order of addition).
  void drop(int position);

 private:
  int n_;
  int k_ = 0;
  Eigen::MatrixXd J_;
  Eigen::MatrixXd R_;
};

}  // namespace mpmpp::detail
