#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <limits>

#include "mpmpp/error.hpp"
#include "mpmpp/qp.hpp"

// Heap-allocation counter for the warm-solve test. Eigen allocates with std::malloc and
// operator new ends in malloc, so counting malloc/calloc/realloc sees every heap allocation:
// under AddressSanitizer through its allocator hooks, otherwise by interposing glibc's malloc.
namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
void note_allocation() {
  if (g_counting.load(std::memory_order_relaxed))
    g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

#if defined(__SANITIZE_ADDRESS__)
// Declared here (public sanitizer ABI) since GCC does not always ship the header.
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*,
                                                                             size_t),
                                                         void (*free_hook)(const volatile void*));
namespace {
void asan_malloc_hook(const volatile void*, size_t) { note_allocation(); }
void asan_free_hook(const volatile void*) {}
const int g_hooks_installed =
    __sanitizer_install_malloc_and_free_hooks(asan_malloc_hook, asan_free_hook);
}  // namespace
#else
extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* malloc(size_t size) {
  note_allocation();
  return __libc_malloc(size);
}
void* calloc(size_t count, size_t size) {
  note_allocation();
  return __libc_calloc(count, size);
}
void* realloc(void* p, size_t size) {
  note_allocation();
  return __libc_realloc(p, size);
}
}
#endif

using Eigen::MatrixXd;
using Eigen::VectorXd;
using mpmpp::QpSolver;
using mpmpp::QpStatus;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

VectorXd vec(std::initializer_list<double> values) {
  VectorXd v(static_cast<Eigen::Index>(values.size()));
  Eigen::Index i = 0;
  for (double value : values) v[i++] = value;
  return v;
}

// KKT in OSQP's convention: P x + q + A'y = 0.
void expect_stationary(const MatrixXd& P, const VectorXd& q, const MatrixXd& A,
                       const mpmpp::QpResult& r) {
  EXPECT_LT((P * r.x + q + A.transpose() * r.y).cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace

TEST(QpSolver, UnconstrainedMinimiser) {
  MatrixXd P(2, 2);
  P << 4, 1, 1, 2;
  const VectorXd q = vec({1, -1});
  const auto r = mpmpp::solve_qp(P, q, MatrixXd(0, 2), VectorXd(0), VectorXd(0));
  EXPECT_EQ(r.status, QpStatus::Solved);
  EXPECT_LT((r.x - P.ldlt().solve(-q)).norm(), 1e-14);
  EXPECT_EQ(r.iterations, 0);
}

TEST(QpSolver, BoxWithDegenerateBound) {
  // min 1/2|x|^2 - 3 x1 + x2 on [-1, 1]^2: x = (1, -1); x2 sits at its bound with zero multiplier.
  const MatrixXd P = MatrixXd::Identity(2, 2), A = MatrixXd::Identity(2, 2);
  const VectorXd q = vec({-3, 1});
  const auto r = mpmpp::solve_qp(P, q, A, vec({-1, -1}), vec({1, 1}));
  ASSERT_EQ(r.status, QpStatus::Solved);
  EXPECT_NEAR(r.x[0], 1.0, 1e-14);
  EXPECT_NEAR(r.x[1], -1.0, 1e-14);
  EXPECT_NEAR(r.y[0], 2.0, 1e-14);  // upper bound active: y > 0
  EXPECT_NEAR(r.y[1], 0.0, 1e-14);
  EXPECT_NEAR(r.objective, 0.5 * 2 - 3 - 1, 1e-14);
}

TEST(QpSolver, EqualityWithDuplicatedAndRedundantRows) {
  // min 1/2|x|^2 s.t. x1 + x2 = 1, given four times (once scaled by 2): x = (1/2, 1/2).
  const MatrixXd P = MatrixXd::Identity(2, 2);
  MatrixXd A(4, 2);
  A << 1, 1, 1, 1, 2, 2, 1, 1;
  const VectorXd b = vec({1, 1, 2, 1});
  const auto r = mpmpp::solve_qp(P, VectorXd::Zero(2), A, b, b);
  ASSERT_EQ(r.status, QpStatus::Solved);
  EXPECT_NEAR(r.x[0], 0.5, 1e-14);
  EXPECT_NEAR(r.x[1], 0.5, 1e-14);
  expect_stationary(P, VectorXd::Zero(2), A, r);
}

TEST(QpSolver, DegenerateVertexWithManyDependentActiveRows) {
  // min 1/2|x - (1, 1)|^2 s.t. five half-planes through the origin: x = 0, at most two rows are
  // independent, the rest must be handled as dependent.
  const MatrixXd P = MatrixXd::Identity(2, 2);
  MatrixXd A(5, 2);
  A << 1, 0, 0, 1, 1, 1, 2, 1, 1, 3;
  const VectorXd q = vec({-1, -1});
  const auto r = mpmpp::solve_qp(P, q, A, VectorXd::Constant(5, -kInf), VectorXd::Zero(5));
  ASSERT_EQ(r.status, QpStatus::Solved);
  EXPECT_LT(r.x.norm(), 1e-14);
  EXPECT_GE(r.y.minCoeff(), 0.0);
  expect_stationary(P, q, A, r);
}

TEST(QpSolver, InfeasibleRowsAndEqualities) {
  const MatrixXd P = MatrixXd::Identity(2, 2);
  MatrixXd A(2, 2);
  A << 1, 0, 1, 0;
  // x1 >= 1 and x1 <= 0 as two rows.
  EXPECT_EQ(mpmpp::solve_qp(P, VectorXd::Zero(2), A, vec({1, -kInf}), vec({kInf, 0})).status,
            QpStatus::PrimalInfeasible);
  // x1 = 1 and x1 = 0.
  EXPECT_EQ(mpmpp::solve_qp(P, VectorXd::Zero(2), A, vec({1, 0}), vec({1, 0})).status,
            QpStatus::PrimalInfeasible);
  // x1 >= 1, x2 >= 1, x1 + x2 <= 1.5.
  MatrixXd C(3, 2);
  C << 1, 0, 0, 1, 1, 1;
  EXPECT_EQ(
      mpmpp::solve_qp(P, VectorXd::Zero(2), C, vec({1, 1, -kInf}), vec({kInf, kInf, 1.5})).status,
      QpStatus::PrimalInfeasible);
}

TEST(QpSolver, BoundsAt1e20AreInfinite) {
  const MatrixXd P = MatrixXd::Identity(1, 1), A = MatrixXd::Identity(1, 1);
  const auto r = mpmpp::solve_qp(P, vec({-5}), A, vec({-1e20}), vec({1e20}));
  ASSERT_EQ(r.status, QpStatus::Solved);
  EXPECT_NEAR(r.x[0], 5.0, 1e-14);
  EXPECT_EQ(r.y[0], 0.0);
}

TEST(QpSolver, BoundsBeyond1e20StayInfiniteWhenTheSolutionCrossesThem) {
  // The unconstrained minimiser lies beyond the "infinite" finite bounds: no row may bind,
  // warm-started or cold, and the next solve (bounds finite again) must still see the row.
  const MatrixXd P = MatrixXd::Identity(1, 1), A = MatrixXd::Identity(1, 1);
  mpmpp::QpSolver solver(P, A);
  for (double target : {5e20, -5e20}) {
    const auto& r = solver.solve(vec({-target}), vec({-1e20}), vec({1e20}));
    ASSERT_EQ(r.status, QpStatus::Solved);
    EXPECT_DOUBLE_EQ(r.x[0], target);
    EXPECT_EQ(r.y[0], 0.0);
  }
  const auto& r = solver.solve(vec({-5e20}), vec({-1}), vec({1}));
  ASSERT_EQ(r.status, QpStatus::Solved);
  EXPECT_DOUBLE_EQ(r.x[0], 1.0);
  EXPECT_DOUBLE_EQ(r.y[0], 5e20 - 1.0);
}

TEST(QpSolver, NonConvexAndIterationCap) {
  const MatrixXd A = MatrixXd::Identity(2, 2);
  const VectorXd one = VectorXd::Ones(2);
  EXPECT_EQ(mpmpp::solve_qp(vec({1, -1}).asDiagonal().toDenseMatrix(), one, A, -one, one).status,
            QpStatus::NonConvex);
  EXPECT_EQ(mpmpp::solve_qp(vec({1, 0}).asDiagonal().toDenseMatrix(), one, A, -one, one).status,
            QpStatus::NonConvex);
  mpmpp::QpSettings settings;
  settings.max_iterations = 1;
  const auto r = mpmpp::solve_qp(MatrixXd::Identity(2, 2), -5 * one, A, -one, one, settings);
  EXPECT_EQ(r.status, QpStatus::MaxIterations);
  EXPECT_EQ(r.iterations, 1);
}

TEST(QpSolver, BadInputThrowsInputError) {
  const MatrixXd P = MatrixXd::Identity(2, 2), A = MatrixXd::Identity(2, 2);
  EXPECT_THROW(QpSolver(MatrixXd::Ones(2, 3), A), mpmpp::InputError);
  EXPECT_THROW(QpSolver(P, MatrixXd::Ones(2, 3)), mpmpp::InputError);
  QpSolver solver(P, A);
  EXPECT_THROW(solver.solve(VectorXd::Zero(3), VectorXd::Zero(2), VectorXd::Zero(2)),
               mpmpp::InputError);
  EXPECT_THROW(solver.solve(VectorXd::Zero(2), vec({1, 0}), vec({0, 0})), mpmpp::InputError);
}

TEST(QpSolver, WarmSolvesReuseActiveSetAndDoNotAllocate) {
  // A receding-horizon-like family: fixed P, A (box + move rows), q and bounds drifting.
  const int n = 6;
  MatrixXd M = MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) M(i, j) = 1.0 / (1.0 + i + j);  // Hilbert-like, well inside PD
  const MatrixXd P = M * M.transpose() + 0.5 * MatrixXd::Identity(n, n);
  MatrixXd A(2 * n, n);
  A << MatrixXd::Identity(n, n), MatrixXd::Identity(n, n);
  for (int i = 1; i < n; ++i) A(n + i, i - 1) = -1.0;  // moves x_i - x_{i-1}
  QpSolver solver(P, A);
  VectorXd q(n), l(2 * n), u(2 * n);
  const auto data = [&](int k) {
    for (int i = 0; i < n; ++i) q[i] = 3.0 * std::sin(0.3 * k + i);
    l.head(n).setConstant(-1.0 - 0.01 * k);
    u.head(n).setConstant(1.0);
    l.tail(n).setConstant(-0.4);
    u.tail(n).setConstant(0.4);
  };
  data(0);
  const auto first = solver.solve(q, l, u);
  ASSERT_EQ(first.status, QpStatus::Solved);
  const auto again = solver.solve(q, l, u);
  EXPECT_EQ(again.iterations, 0);
  EXPECT_LT((again.x - first.x).norm(), 1e-13);

  long iterations = 0;
  for (int k = 1; k <= 50; ++k) {
    data(k);
    g_allocations = 0;
    g_counting = true;
    const mpmpp::QpResult& r = solver.solve(q, l, u);
    g_counting = false;
    EXPECT_EQ(g_allocations.load(), 0) << "solve " << k;
    ASSERT_EQ(r.status, QpStatus::Solved);
    iterations += r.iterations;
    // Same answer as a cold solve of the same problem.
    const auto cold = mpmpp::solve_qp(P, q, A, l, u);
    EXPECT_LT((r.x - cold.x).cwiseAbs().maxCoeff(), 1e-10) << "solve " << k;
    expect_stationary(P, q, A, r);
  }
  EXPECT_GT(iterations, 0);  // the active set did move along the sequence
  // The counter itself works: a cold one-shot solve allocates.
  g_allocations = 0;
  g_counting = true;
  mpmpp::solve_qp(P, q, A, l, u);
  g_counting = false;
  EXPECT_GT(g_allocations.load(), 0);
}
