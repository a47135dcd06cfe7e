#include "mpmpp/qp.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <chrono>

#include "bindings.hpp"
#include "mpmpp/error.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

QpSettings make_settings(int max_iterations, double feasibility_tol, double optimality_tol,
                         double dependency_tol) {
  QpSettings s;
  s.max_iterations = max_iterations;
  s.feasibility_tol = feasibility_tol;
  s.optimality_tol = optimality_tol;
  s.dependency_tol = dependency_tol;
  return s;
}

// A may come as shape (0,) or (0, n) for "no constraints"; give it n columns.
Eigen::MatrixXd as_constraint_matrix(const Eigen::Ref<const Eigen::MatrixXd>& A, Eigen::Index n) {
  if (A.rows() == 0) return Eigen::MatrixXd(0, n);
  return A;
}

// Per-solve wall times (seconds) of warm-started solves of a sequence, measured inside C++ so
// that Python-call overhead does not enter. Each repeat restarts cold at the first problem.
RowMatrix time_sequence(QpSolver& solver, const Eigen::Ref<const RowMatrix>& Q,
                        const Eigen::Ref<const RowMatrix>& L, const Eigen::Ref<const RowMatrix>& U,
                        int repeats) {
  if (Q.cols() != solver.num_variables()) throw InputError("Q must have one q per row");
  if (L.cols() != solver.num_constraints() || U.cols() != solver.num_constraints() ||
      L.rows() != Q.rows() || U.rows() != Q.rows())
    throw InputError("L and U must have one l/u per row, as many rows as Q");
  if (repeats < 1) throw InputError("repeats must be >= 1");
  RowMatrix seconds(repeats, Q.rows());
  Eigen::VectorXd q(Q.cols()), l(L.cols()), u(U.cols());
  for (int rep = 0; rep < repeats; ++rep) {
    solver.reset_warm_start();
    for (Eigen::Index k = 0; k < Q.rows(); ++k) {
      q = Q.row(k).transpose();
      l = L.row(k).transpose();
      u = U.row(k).transpose();
      const auto start = std::chrono::steady_clock::now();
      solver.solve(q, l, u);
      const auto stop = std::chrono::steady_clock::now();
      seconds(rep, k) = std::chrono::duration<double>(stop - start).count();
    }
  }
  return seconds;
}

}  // namespace

void bind_qp(py::module_& m) {
  py::class_<QpResult>(m, "QpResult",
                       "Solution of a QP: x, duals y (OSQP sign), status, iterations, objective")
      .def_readonly("x", &QpResult::x)
      .def_readonly("y", &QpResult::y)
      .def_property_readonly("status",
                             [](const QpResult& r) { return std::string(to_string(r.status)); })
      .def_readonly("iterations", &QpResult::iterations)
      .def_readonly("objective", &QpResult::objective)
      .def("__repr__", [](const QpResult& r) {
        return std::string("QpResult(status='") + to_string(r.status) +
               "', iterations=" + std::to_string(r.iterations) +
               ", objective=" + std::to_string(r.objective) + ")";
      });

  const QpSettings defaults;
  py::class_<QpSolver>(
      m, "QpSolver",
      "Dense dual active-set (Goldfarb-Idnani) solver for min 1/2 x'Px + q'x s.t. l <= Ax <= u\n"
      "with fixed P, A; each solve(q, l, u) warm-starts from the previous active set.")
      .def(py::init([](const Eigen::Ref<const Eigen::MatrixXd>& P,
                       const Eigen::Ref<const Eigen::MatrixXd>& A, int max_iterations,
                       double feasibility_tol, double optimality_tol, double dependency_tol) {
             return QpSolver(
                 P, as_constraint_matrix(A, P.rows()),
                 make_settings(max_iterations, feasibility_tol, optimality_tol, dependency_tol));
           }),
           py::arg("P"), py::arg("A"), py::arg("max_iterations") = defaults.max_iterations,
           py::arg("feasibility_tol") = defaults.feasibility_tol,
           py::arg("optimality_tol") = defaults.optimality_tol,
           py::arg("dependency_tol") = defaults.dependency_tol)
      // A solve takes microseconds: keeping the GIL costs less than releasing it and keeps
      // concurrent Python threads from sharing one solver's workspace.
      .def("solve", &QpSolver::solve, py::arg("q"), py::arg("l"), py::arg("u"),
           py::return_value_policy::copy,
           "Solve with the given q, l, u, warm-started from the previous active set")
      .def("reset_warm_start", &QpSolver::reset_warm_start)
      .def_property_readonly("num_variables", &QpSolver::num_variables)
      .def_property_readonly("num_constraints", &QpSolver::num_constraints)
      .def("time_sequence", &time_sequence, py::arg("Q"), py::arg("L"), py::arg("U"),
           py::arg("repeats") = 1,
           "Per-solve seconds (repeats x len(Q)) of warm-started solves timed inside C++",
           py::call_guard<py::gil_scoped_release>());

  m.def(
      "solve_qp",
      [](const Eigen::Ref<const Eigen::MatrixXd>& P, const Eigen::Ref<const Eigen::VectorXd>& q,
         const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::VectorXd>& l,
         const Eigen::Ref<const Eigen::VectorXd>& u, int max_iterations, double feasibility_tol,
         double optimality_tol, double dependency_tol) {
        return solve_qp(
            P, q, as_constraint_matrix(A, P.rows()), l, u,
            make_settings(max_iterations, feasibility_tol, optimality_tol, dependency_tol));
      },
      py::arg("P"), py::arg("q"), py::arg("A"), py::arg("l"), py::arg("u"),
      py::arg("max_iterations") = defaults.max_iterations,
      py::arg("feasibility_tol") = defaults.feasibility_tol,
      py::arg("optimality_tol") = defaults.optimality_tol,
      py::arg("dependency_tol") = defaults.dependency_tol,
      "Solve min 1/2 x'Px + q'x s.t. l <= Ax <= u once (dense dual active-set method)");
}

}  // namespace mpmpp::bindings
