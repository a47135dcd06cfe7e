#include "mpmpp/one_class_svm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "gaussian_kernel.hpp"
#include "kernel_columns.hpp"
#include "mpmpp/error.hpp"
#include "simd4.hpp"

namespace mpmpp {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Floor for a non-positive quadratic coefficient in the two-variable subproblem (libsvm's TAU).
constexpr double kTau = 1e-12;

using detail::KernelColumns;
using detail::Vec4;
using detail::Vec4f;
using detail::Vec4i;
using Eigen::Index;

// The two scans of the working-set selection (select_working_set below), 4 lanes at a time and
// two lane groups (independent dependency chains). Every lane keeps its best value and the last
// index reaching it; merging the lanes by (best value, then largest index) and finishing the
// tail in order gives exactly the index the plain sequential scan with ">=" / "<=" picks, and
// the arithmetic per element is the same (2 q is exact, so a fused 2 - 2 q rounds as the
// separate operations do). Bound masks come from alpha itself (upper: alpha >= 1, lower:
// alpha <= 0, the solver's status rule).
struct LaneBest {
  Vec4 value;
  Vec4i index;
};

// Merge the lanes: the best value (larger when maximise, else smaller), ties to the largest index.
template <bool maximise>
int merge_lanes(const LaneBest* groups, int n_groups, double& best) {
  int idx = -1;
  for (int g = 0; g < n_groups; ++g)
    for (int k = 0; k < 4; ++k) {
      const double v = groups[g].value[k];
      const int i = static_cast<int>(groups[g].index[k]);
      if (i != -1 && (idx == -1 || (maximise ? v > best : v < best) || (v == best && i > idx))) {
        best = v;
        idx = i;
      }
    }
  return idx;
}

// i = the last t < n with alpha_t < 1 maximising -G_t; gmax = -G_i (-inf and -1 when none).
MPMPP_CPU_CLONES
int max_violating_up(const double* grad, const double* alpha, int n, double& gmax) {
  const Vec4 one = {1.0, 1.0, 1.0, 1.0};
  LaneBest lane[2];
  for (LaneBest& l : lane) {
    l.value = -one * kInf;
    l.index = Vec4i{} - 1;
  }
  Vec4i idx = {0, 1, 2, 3};
  int t = 0;
  for (; t + 8 <= n; t += 8, idx += 8)
    for (int g = 0; g < 2; ++g) {
      Vec4 v, a;
      MPMPP_LOAD4(v, grad + t + 4 * g);
      MPMPP_LOAD4(a, alpha + t + 4 * g);
      v = -v;
      const Vec4i take = (a < one) & (v >= lane[g].value);
      lane[g].value = take ? v : lane[g].value;
      lane[g].index = take ? idx + 4 * g : lane[g].index;
    }
  gmax = -kInf;
  int i = merge_lanes<true>(lane, 2, gmax);
  for (; t < n; ++t)
    if (alpha[t] < 1.0 && -grad[t] >= gmax) {
      gmax = -grad[t];
      i = t;
    }
  if (i != -1) gmax = -grad[i];
  return i;
}

// j = the last t < n with alpha_t > 0 and G_t > -gmax minimising the second-order objective
// change -(gmax + G_t)^2 / (Q_ii + Q_tt - 2 Q_it) (Q_tt = 1, q_i = column i; -1 when none);
// gmax2 = max G_t over alpha_t > 0.
MPMPP_CPU_CLONES
int second_order_partner(const double* grad, const double* alpha, const float* q_i, double gmax,
                         int n, double& gmax2) {
  const Vec4 zero = {}, one = {1.0, 1.0, 1.0, 1.0}, tau = one * kTau;
  LaneBest lane[2];
  Vec4 g_best[2];
  for (int g = 0; g < 2; ++g) {
    lane[g].value = one * kInf;
    lane[g].index = Vec4i{} - 1;
    g_best[g] = -one * kInf;
  }
  Vec4i idx = {0, 1, 2, 3};
  int t = 0;
  // Without an i (gmax = -inf) no G_t - G_i is positive and q_i is never read.
  const int n_vec = q_i != nullptr ? n : 0;
  for (; t + 8 <= n_vec; t += 8, idx += 8)
    for (int g = 0; g < 2; ++g) {
      Vec4 grad_t, a;
      MPMPP_LOAD4(grad_t, grad + t + 4 * g);
      MPMPP_LOAD4(a, alpha + t + 4 * g);
      Vec4f qf;
      __builtin_memcpy(&qf, q_i + t + 4 * g, sizeof qf);
      const Vec4i up = a > zero;
      g_best[g] = (up & (grad_t >= g_best[g])) ? grad_t : g_best[g];
      const Vec4 grad_diff = gmax + grad_t;
      const Vec4 quad_coef = 2.0 - 2.0 * __builtin_convertvector(qf, Vec4);
      const Vec4 obj_diff = -(grad_diff * grad_diff) / (quad_coef > zero ? quad_coef : tau);
      const Vec4i take = up & (grad_diff > zero) & (obj_diff <= lane[g].value);
      lane[g].value = take ? obj_diff : lane[g].value;
      lane[g].index = take ? idx + 4 * g : lane[g].index;
    }
  gmax2 = -kInf;
  for (const Vec4& v : g_best)
    for (int k = 0; k < 4; ++k) gmax2 = std::max(gmax2, v[k]);
  double obj_diff_min = kInf;
  int j = merge_lanes<false>(lane, 2, obj_diff_min);
  for (; t < n; ++t) {
    if (!(alpha[t] > 0.0)) continue;
    const double grad_diff = gmax + grad[t];
    if (grad[t] >= gmax2) gmax2 = grad[t];
    if (grad_diff > 0) {
      const double quad_coef = 2.0 - 2.0 * q_i[t];
      const double obj_diff = -(grad_diff * grad_diff) / (quad_coef > 0 ? quad_coef : kTau);
      if (obj_diff <= obj_diff_min) {
        j = t;
        obj_diff_min = obj_diff;
      }
    }
  }
  return j;
}

// SMO for  min 1/2 alpha' Q alpha  s.t.  0 <= alpha_i <= 1,  sum alpha_i = nu l  (the libsvm
// scaling of eqs 18-19). This is libsvm's Solver specialised to one class (y_i = +1, p = 0,
// C_i = 1): maximal-violating i, second-order j (Fan, Chen & Lin 2005, WSS 2), shrinking every
// min(l, 1000) iterations, gradient reconstruction before the final optimality check.
class SmoSolver {
 public:
  SmoSolver(KernelColumns& q, double tol, bool shrinking, std::int64_t max_iter)
      : q_(q),
        l_(q.size()),
        tol_(tol),
        shrinking_(shrinking),
        max_iter_(max_iter),
        alpha_(l_),
        grad_(l_),
        grad_bar_(l_),
        status_(l_),
        active_set_(l_),
        active_size_(l_) {}

  struct Result {
    Eigen::VectorXd alpha;  // original order
    double rho;
    double objective;
    std::int64_t iterations;
    bool converged;
  };

  Result solve(double nu) {
    initial_point(nu);
    initial_gradient();
    std::int64_t iter = 0;
    bool converged = true;
    int counter = std::min(l_, 1000) + 1;
    while (true) {
      if (max_iter_ != -1 && iter >= max_iter_) {
        converged = false;
        break;
      }
      if (--counter == 0) {
        counter = std::min(l_, 1000);
        if (shrinking_) do_shrinking();
      }
      int i = -1, j = -1;
      if (select_working_set(i, j)) {
        // Optimal on the active set: check again on the whole set.
        reconstruct_gradient();
        active_size_ = l_;
        if (select_working_set(i, j)) break;
        counter = 1;  // shrink at the next iteration
      }
      ++iter;
      update_pair(i, j);
    }
    Result r;
    r.rho = calculate_rho();
    double v = 0.0;
    for (int i = 0; i < l_; ++i) v += alpha_[i] * grad_[i];
    r.objective = v / 2;
    r.alpha.resize(l_);
    for (int i = 0; i < l_; ++i) r.alpha[active_set_[i]] = alpha_[i];
    r.iterations = iter;
    r.converged = converged;
    return r;
  }

 private:
  enum Status : char { kLower, kUpper, kFree };
  bool is_upper(int i) const { return status_[i] == kUpper; }
  bool is_lower(int i) const { return status_[i] == kLower; }
  bool is_free(int i) const { return status_[i] == kFree; }
  void update_status(int i) {
    status_[i] = alpha_[i] >= 1.0 ? kUpper : (alpha_[i] <= 0.0 ? kLower : kFree);
  }

  // libsvm's feasible start: alpha = (1, ..., 1, frac, 0, ..., 0) with sum nu l. nu l is
  // accumulated point by point (as scikit-learn does with per-sample weights), so a tiny
  // round-off remainder may start as a free variable exactly as it does there.
  void initial_point(double nu) {
    double nu_l = 0.0;
    for (int i = 0; i < l_; ++i) nu_l += nu;
    int i = 0;
    for (; nu_l > 0 && i < l_; ++i) {
      alpha_[i] = std::min(1.0, nu_l);
      nu_l -= alpha_[i];
    }
    for (; i < l_; ++i) alpha_[i] = 0.0;
    for (i = 0; i < l_; ++i) {
      update_status(i);
      active_set_[i] = i;
    }
  }

  // G = Q alpha and G_bar = sum_{alpha_i = 1} Q_i. The non-zero alphas are a prefix, so the
  // columns are produced in tiles by matrix products (this is where most of the start-up cost
  // of a large nu l goes) and rounded to single precision like cached columns.
  void initial_gradient() {
    grad_.setZero();
    grad_bar_.setZero();
    int n_nonzero = 0;
    while (n_nonzero < l_ && alpha_[n_nonzero] > 0) ++n_nonzero;
    constexpr int kCols = 64;
    Eigen::MatrixXf tile;
    for (int c0 = 0; c0 < n_nonzero; c0 += kCols) {
      const int nc = std::min(kCols, n_nonzero - c0);
      q_.full_columns(c0, nc, tile);
      for (int k = 0; k < nc; ++k) {
        const int i = c0 + k;
        // Column by column, so every G_j accumulates alpha_i Q_ij in increasing i as libsvm
        // does: the iterates then follow libsvm's to the last bit wherever Q agrees.
        grad_ += alpha_[i] * tile.col(k).cast<double>();
        if (is_upper(i)) grad_bar_ += tile.col(k).cast<double>();
        q_.insert(i, tile.col(k).data());  // libsvm's start-up leaves these columns cached too
      }
    }
  }

  // i maximises -G over I_up; j minimises the second-order decrease -(G_i - G_j)^2 / (2 - 2 Q_ij)
  // over I_low with G_j > G_i. Returns true when the violation max(-G, I_up) + max(G, I_low)
  // is below tol (or no pair improves), i.e. the KKT conditions hold to tol.
  bool select_working_set(int& out_i, int& out_j) {
    double gmax, gmax2;
    const int i = max_violating_up(grad_.data(), alpha_.data(), active_size_, gmax);
    if (i != -1 && q_.cached_length(i) == 0) prefetch_with(i);
    const float* q_i = i != -1 ? q_.column(i, active_size_) : nullptr;
    const int j = second_order_partner(grad_.data(), alpha_.data(), q_i, gmax, active_size_, gmax2);
    if (gmax + gmax2 < tol_ || j == -1) return true;
    out_i = i;
    out_j = j;
    return false;
  }

  // Column i is about to be computed: compute it together with the columns of the three
  // uncached points of I_up with the next largest violations -G_t, which are the likeliest next
  // i's (a point entering the support set usually has no cached column yet), in one pass over
  // the data (KernelColumns::compute_four). Only when the cache holds them without evicting
  // anything, so the guess never costs a useful column; it never changes a value either.
  void prefetch_with(int i) {
    if (q_.free_columns(active_size_) < 4) return;
    int top[4] = {i, -1, -1, -1};
    double value[4] = {kInf, -kInf, -kInf, -kInf};  // -G of top[1..3], descending
    for (int t = 0; t < active_size_; ++t) {
      if (!(alpha_[t] < 1.0) || t == i || -grad_[t] <= value[3] || q_.cached_length(t) != 0)
        continue;
      int k = 3;
      for (; k > 1 && -grad_[t] > value[k - 1]; --k) {
        value[k] = value[k - 1];
        top[k] = top[k - 1];
      }
      value[k] = -grad_[t];
      top[k] = t;
    }
    if (top[3] == -1) return;
    std::swap(top[0], top[3]);  // i last: the most recently used
    q_.compute_four(top, active_size_);
  }

  // Exact minimisation over (alpha_i, alpha_j) with alpha_i + alpha_j fixed, clipped to the box.
  void update_pair(int i, int j) {
    const float* q_i = q_.column(i, active_size_);
    const float* q_j = q_.column(j, active_size_);
    const double old_i = alpha_[i], old_j = alpha_[j];
    double quad_coef = 2.0 - 2.0 * q_i[j];
    if (quad_coef <= 0) quad_coef = kTau;
    const double delta = (grad_[i] - grad_[j]) / quad_coef;
    const double sum = alpha_[i] + alpha_[j];
    alpha_[i] -= delta;
    alpha_[j] += delta;
    if (sum > 1.0) {
      if (alpha_[i] > 1.0) {
        alpha_[i] = 1.0;
        alpha_[j] = sum - 1.0;
      }
    } else if (alpha_[j] < 0) {
      alpha_[j] = 0;
      alpha_[i] = sum;
    }
    if (sum > 1.0) {
      if (alpha_[j] > 1.0) {
        alpha_[j] = 1.0;
        alpha_[i] = sum - 1.0;
      }
    } else if (alpha_[i] < 0) {
      alpha_[i] = 0;
      alpha_[j] = sum;
    }
    const double d_i = alpha_[i] - old_i, d_j = alpha_[j] - old_j;
    for (int k = 0; k < active_size_; ++k) grad_[k] += q_i[k] * d_i + q_j[k] * d_j;

    const bool was_upper_i = is_upper(i), was_upper_j = is_upper(j);
    update_status(i);
    update_status(j);
    update_grad_bar(i, was_upper_i);
    update_grad_bar(j, was_upper_j);
  }

  void update_grad_bar(int i, bool was_upper) {
    if (was_upper == is_upper(i)) return;
    const float* q_i = q_.column(i, l_);
    const double sign = was_upper ? -1.0 : 1.0;
    for (int k = 0; k < l_; ++k) grad_bar_[k] += sign * q_i[k];
  }

  // G of the shrunk (inactive) points from G_bar and the free variables.
  void reconstruct_gradient() {
    if (active_size_ == l_) return;
    for (int j = active_size_; j < l_; ++j) grad_[j] = grad_bar_[j];
    std::int64_t nr_free = 0;
    for (int j = 0; j < active_size_; ++j)
      if (is_free(j)) ++nr_free;
    if (nr_free * l_ > 2 * static_cast<std::int64_t>(active_size_) * (l_ - active_size_)) {
      for (int i = active_size_; i < l_; ++i) {
        const float* q_i = q_.column(i, active_size_);
        for (int j = 0; j < active_size_; ++j)
          if (is_free(j)) grad_[i] += alpha_[j] * q_i[j];
      }
    } else {
      for (int i = 0; i < active_size_; ++i)
        if (is_free(i)) {
          const float* q_i = q_.column(i, l_);
          const double a = alpha_[i];
          for (int j = active_size_; j < l_; ++j) grad_[j] += a * q_i[j];
        }
    }
  }

  bool be_shrunk(int i, double gmax1, double gmax2) const {
    if (is_upper(i)) return -grad_[i] > gmax1;
    if (is_lower(i)) return grad_[i] > gmax2;
    return false;
  }

  // Move bounded variables that cannot enter a violating pair to the inactive tail.
  void do_shrinking() {
    double gmax1 = -kInf, gmax2 = -kInf;
    for (int i = 0; i < active_size_; ++i) {
      if (!is_upper(i) && -grad_[i] >= gmax1) gmax1 = -grad_[i];
      if (!is_lower(i) && grad_[i] >= gmax2) gmax2 = grad_[i];
    }
    if (!unshrink_ && gmax1 + gmax2 <= tol_ * 10) {
      // Close to the end: unshrink once so the final iterations see every point.
      unshrink_ = true;
      reconstruct_gradient();
      active_size_ = l_;
    }
    for (int i = 0; i < active_size_; ++i)
      if (be_shrunk(i, gmax1, gmax2)) {
        --active_size_;
        while (active_size_ > i) {
          if (!be_shrunk(active_size_, gmax1, gmax2)) {
            swap_index(i, active_size_);
            break;
          }
          --active_size_;
        }
      }
  }

  void swap_index(int i, int j) {
    q_.swap_index(i, j);
    std::swap(grad_[i], grad_[j]);
    std::swap(status_[i], status_[j]);
    std::swap(alpha_[i], alpha_[j]);
    std::swap(active_set_[i], active_set_[j]);
    std::swap(grad_bar_[i], grad_bar_[j]);
  }

  // rho = mean gradient over free variables (where the KKT conditions make G_i = rho), else the
  // midpoint of the feasible interval [max G over upper-bounded, min G over lower-bounded].
  double calculate_rho() const {
    double ub = kInf, lb = -kInf, sum_free = 0.0;
    int nr_free = 0;
    for (int i = 0; i < active_size_; ++i) {
      if (is_upper(i))
        lb = std::max(lb, grad_[i]);
      else if (is_lower(i))
        ub = std::min(ub, grad_[i]);
      else {
        ++nr_free;
        sum_free += grad_[i];
      }
    }
    if (nr_free > 0) return sum_free / nr_free;
    // nu = 1 puts every alpha at the upper bound: any rho >= max G is optimal and libsvm's
    // midpoint would be +inf. Take the finite end, so the best training point scores 0.
    if (ub == kInf) return lb;
    return (ub + lb) / 2;
  }

  KernelColumns& q_;
  int l_;
  double tol_;
  bool shrinking_;
  std::int64_t max_iter_;
  Eigen::VectorXd alpha_, grad_, grad_bar_;
  std::vector<char> status_;
  std::vector<int> active_set_;
  int active_size_;
  bool unshrink_ = false;
};

}  // namespace

OneClassSvmModel fit_one_class_svm(const Eigen::Ref<const RowMatrixXd>& X,
                                   const OneClassSvmOptions& options) {
  if (X.rows() < 1 || X.cols() < 1)
    throw InputError("X: need at least one sample and one feature, got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()));
  if (X.rows() > std::numeric_limits<int>::max() / 2)
    throw InputError("X: too many samples for the SMO solver");
  detail::require_finite(X, "X");
  if (!(options.nu > 0 && options.nu <= 1))
    throw InputError("nu: must be in (0, 1], got " + std::to_string(options.nu));
  detail::check_kernel_scale(options.kernel_scale);
  if (!(options.tol > 0) || !std::isfinite(options.tol))
    throw InputError("tol: must be a finite number > 0, got " + std::to_string(options.tol));
  if (!(options.cache_mb > 0) || !std::isfinite(options.cache_mb))
    throw InputError("cache_mb: must be a finite number > 0, got " +
                     std::to_string(options.cache_mb));
  if (options.max_iter == 0 || options.max_iter < -1)
    throw InputError("max_iter: must be -1 (no limit) or > 0, got " +
                     std::to_string(options.max_iter));

  KernelColumns q(X, 1.0 / options.kernel_scale, options.cache_mb);
  SmoSolver solver(q, options.tol, options.shrinking, options.max_iter);
  const SmoSolver::Result r = solver.solve(options.nu);

  OneClassSvmModel model;
  const int l = static_cast<int>(X.rows());
  int n_sv = 0;
  for (int i = 0; i < l; ++i)
    if (r.alpha[i] > 0) ++n_sv;
  model.support.resize(n_sv);
  model.dual_coef.resize(n_sv);
  model.support_vectors.resize(n_sv, X.cols());
  for (int i = 0, k = 0; i < l; ++i)
    if (r.alpha[i] > 0) {
      model.support[k] = i;
      model.dual_coef[k] = r.alpha[i];
      model.support_vectors.row(k) = X.row(i);
      ++k;
    }
  model.rho = r.rho;
  model.kernel_scale = options.kernel_scale;
  model.nu = options.nu;
  model.n_train = l;
  model.iterations = r.iterations;
  model.converged = r.converged;
  model.objective = r.objective;
  return model;
}

Eigen::VectorXd OneClassSvmModel::score_samples(const Eigen::Ref<const RowMatrixXd>& X) const {
  return gaussian_kernel_expansion(support_vectors, dual_coef, kernel_scale, X, 1);
}

Eigen::VectorXd OneClassSvmModel::decision_function(const Eigen::Ref<const RowMatrixXd>& X) const {
  return (score_samples(X).array() - rho).matrix();
}

}  // namespace mpmpp
