#include "mpmpp/one_class_svm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "mpmpp/error.hpp"

namespace mpmpp {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Floor for a non-positive quadratic coefficient in the two-variable subproblem (libsvm's TAU).
constexpr double kTau = 1e-12;

using Eigen::Index;

// Gaussian kernel matrix Q_ij = exp(-gamma ||x_i - x_j||^2), gamma = 1/c (eq 15), seen through
// the solver's current permutation of the training points (shrinking moves inactive points to
// the end). Columns are computed on demand with one matrix-vector product, stored in single
// precision (as libsvm does, which halves memory and keeps our iterates on libsvm's path) and
// kept in a least-recently-used cache bounded in bytes. Q_ii = 1 exactly for this kernel.
class KernelColumns {
 public:
  KernelColumns(const Eigen::Ref<const RowMatrixXd>& X, double gamma, double cache_mb)
      : x_(X), sq_norm_(X.rowwise().squaredNorm()), gamma_(gamma), l_(static_cast<int>(X.rows())),
        columns_(static_cast<size_t>(l_) + 1), dots_(l_) {
    const double bytes = cache_mb * 1024.0 * 1024.0;
    const double floats = bytes / sizeof(float) - 8.0 * l_;  // minus bookkeeping, like libsvm
    // At least two full columns, so fetching Q_j never evicts the Q_i fetched just before it.
    budget_ = std::max<std::int64_t>(
        static_cast<std::int64_t>(std::min(floats, 9.0e18)), 2 * static_cast<std::int64_t>(l_));
    sentinel().prev = sentinel().next = l_;
  }

  int size() const { return l_; }
  double gamma() const { return gamma_; }
  const RowMatrixXd& points() const { return x_; }
  const Eigen::VectorXd& squared_norms() const { return sq_norm_; }

  // Q_i[0, len): the first len entries of column i in the current order.
  const float* column(int i, int len) {
    Column& h = columns_[i];
    if (h.len > 0) unlink(i);
    const int start = h.len;
    const std::int64_t more = len - h.len;
    if (more > 0) {
      while (budget_ < more) evict(sentinel().next);
      h.data.resize(len);
      budget_ -= more;
      fill(i, start, len, h.data.data());
      h.len = len;
    }
    link_last(i);
    return h.data.data();
  }

  // Exchange points i and j in the solver order; cached columns follow (or are dropped when
  // they cover only one of the two positions).
  void swap_index(int i, int j) {
    if (i == j) return;
    x_.row(i).swap(x_.row(j));
    std::swap(sq_norm_[i], sq_norm_[j]);
    if (columns_[i].len > 0) unlink(i);
    if (columns_[j].len > 0) unlink(j);
    std::swap(columns_[i].data, columns_[j].data);
    std::swap(columns_[i].len, columns_[j].len);
    if (columns_[i].len > 0) link_last(i);
    if (columns_[j].len > 0) link_last(j);
    if (i > j) std::swap(i, j);
    for (int h = sentinel().next; h != l_;) {
      const int next = columns_[h].next;
      Column& c = columns_[h];
      if (c.len > i) {
        if (c.len > j)
          std::swap(c.data[i], c.data[j]);
        else
          evict(h);
      }
      h = next;
    }
  }

 private:
  struct Column {
    std::vector<float> data;
    int len = 0;
    int prev = -1, next = -1;
  };

  Column& sentinel() { return columns_[l_]; }

  void unlink(int h) {
    columns_[columns_[h].prev].next = columns_[h].next;
    columns_[columns_[h].next].prev = columns_[h].prev;
  }
  void link_last(int h) {
    columns_[h].next = l_;
    columns_[h].prev = sentinel().prev;
    columns_[sentinel().prev].next = h;
    sentinel().prev = h;
  }
  void evict(int h) {
    unlink(h);
    budget_ += columns_[h].len;
    std::vector<float>().swap(columns_[h].data);
    columns_[h].len = 0;
  }

  void fill(int i, int start, int len, float* out) {
    const int n = len - start;
    auto dots = dots_.head(n);
    dots.noalias() = x_.middleRows(start, n) * x_.row(i).transpose();
    // Same expression as libsvm's RBF kernel: exp(-gamma (|x_i|^2 + |x_j|^2 - 2 x_i.x_j)).
    for (int t = 0; t < n; ++t)
      out[start + t] =
          static_cast<float>(std::exp(-gamma_ * (sq_norm_[i] + sq_norm_[start + t] - 2 * dots[t])));
  }

  RowMatrixXd x_;
  Eigen::VectorXd sq_norm_;
  double gamma_;
  int l_;
  std::vector<Column> columns_;  // l_ heads plus the LRU list's sentinel at index l_
  std::int64_t budget_;          // floats still available
  Eigen::VectorXd dots_;
};

// SMO for  min 1/2 alpha' Q alpha  s.t.  0 <= alpha_i <= 1,  sum alpha_i = nu l  (the libsvm
// scaling of eqs 18-19). This is libsvm's Solver specialised to one class (y_i = +1, p = 0,
// C_i = 1): maximal-violating i, second-order j (Fan, Chen & Lin 2005, WSS 2), shrinking every
// min(l, 1000) iterations, gradient reconstruction before the final optimality check.
class SmoSolver {
 public:
  SmoSolver(KernelColumns& q, double tol, bool shrinking, std::int64_t max_iter)
      : q_(q), l_(q.size()), tol_(tol), shrinking_(shrinking), max_iter_(max_iter),
        alpha_(l_), grad_(l_), grad_bar_(l_), status_(l_), active_set_(l_), active_size_(l_) {}

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
    const RowMatrixXd& x = q_.points();
    const Eigen::VectorXd& sq = q_.squared_norms();
    const double gamma = q_.gamma();
    constexpr int kRows = 2048, kCols = 256;
    Eigen::MatrixXd tile;
    Eigen::VectorXd upper(kCols);
    for (int c0 = 0; c0 < n_nonzero; c0 += kCols) {
      const int nc = std::min(kCols, n_nonzero - c0);
      for (int k = 0; k < nc; ++k) upper[k] = is_upper(c0 + k) ? 1.0 : 0.0;
      for (int r0 = 0; r0 < l_; r0 += kRows) {
        const int nr = std::min(kRows, l_ - r0);
        tile.noalias() = x.middleRows(r0, nr) * x.middleRows(c0, nc).transpose();
        // Same expression as in KernelColumns::fill, rounded to single precision like Q.
        tile = ((-2.0 * tile).colwise() + sq.segment(r0, nr)).rowwise() +
               sq.segment(c0, nc).transpose();
        tile = (-gamma * tile.array()).exp().cast<float>().cast<double>().matrix();
        // Column by column, so every G_j accumulates alpha_i Q_ij in increasing i as libsvm
        // does: the iterates then follow libsvm's to the last bit wherever Q agrees.
        for (int k = 0; k < nc; ++k) {
          grad_.segment(r0, nr) += alpha_[c0 + k] * tile.col(k);
          if (upper[k] != 0.0) grad_bar_.segment(r0, nr) += tile.col(k);
        }
      }
    }
  }

  // i maximises -G over I_up; j minimises the second-order decrease -(G_i - G_j)^2 / (2 - 2 Q_ij)
  // over I_low with G_j > G_i. Returns true when the violation max(-G, I_up) + max(G, I_low)
  // is below tol (or no pair improves), i.e. the KKT conditions hold to tol.
  bool select_working_set(int& out_i, int& out_j) {
    double gmax = -kInf;
    int gmax_idx = -1;
    for (int t = 0; t < active_size_; ++t)
      if (!is_upper(t) && -grad_[t] >= gmax) {
        gmax = -grad_[t];
        gmax_idx = t;
      }
    const int i = gmax_idx;
    const float* q_i = i != -1 ? q_.column(i, active_size_) : nullptr;
    double gmax2 = -kInf;
    int gmin_idx = -1;
    double obj_diff_min = kInf;
    for (int j = 0; j < active_size_; ++j) {
      if (is_lower(j)) continue;
      const double grad_diff = gmax + grad_[j];
      if (grad_[j] >= gmax2) gmax2 = grad_[j];
      if (grad_diff > 0) {
        const double quad_coef = 2.0 - 2.0 * q_i[j];  // Q_ii + Q_jj - 2 Q_ij
        const double obj_diff = -(grad_diff * grad_diff) / (quad_coef > 0 ? quad_coef : kTau);
        if (obj_diff <= obj_diff_min) {
          gmin_idx = j;
          obj_diff_min = obj_diff;
        }
      }
    }
    if (gmax + gmax2 < tol_ || gmin_idx == -1) return true;
    out_i = gmax_idx;
    out_j = gmin_idx;
    return false;
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

void require_finite(const Eigen::Ref<const RowMatrixXd>& X, const char* name) {
  if (!X.allFinite()) throw InputError(std::string(name) + ": contains NaN or infinite values");
}

void check_kernel_scale(double c) {
  if (!(c > 0) || !std::isfinite(c))
    throw InputError("kernel_scale: must be a finite number > 0, got " + std::to_string(c));
}

}  // namespace

OneClassSvmModel fit_one_class_svm(const Eigen::Ref<const RowMatrixXd>& X,
                                   const OneClassSvmOptions& options) {
  if (X.rows() < 1 || X.cols() < 1)
    throw InputError("X: need at least one sample and one feature, got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()));
  if (X.rows() > std::numeric_limits<int>::max() / 2)
    throw InputError("X: too many samples for the SMO solver");
  require_finite(X, "X");
  if (!(options.nu > 0 && options.nu <= 1))
    throw InputError("nu: must be in (0, 1], got " + std::to_string(options.nu));
  check_kernel_scale(options.kernel_scale);
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

Eigen::VectorXd gaussian_kernel_expansion(const Eigen::Ref<const RowMatrixXd>& support_vectors,
                                          const Eigen::Ref<const Eigen::VectorXd>& coef,
                                          double kernel_scale,
                                          const Eigen::Ref<const RowMatrixXd>& X, int n_threads) {
  check_kernel_scale(kernel_scale);
  if (coef.size() != support_vectors.rows())
    throw InputError("coef: length " + std::to_string(coef.size()) + " does not match " +
                     std::to_string(support_vectors.rows()) + " support vectors");
  if (X.cols() != support_vectors.cols())
    throw InputError("X: has " + std::to_string(X.cols()) + " features, the model expects " +
                     std::to_string(support_vectors.cols()));
  require_finite(X, "X");
  const Index n = X.rows();
  Eigen::VectorXd out = Eigen::VectorXd::Zero(n);
  if (n == 0 || support_vectors.rows() == 0) return out;

  const double gamma = 1.0 / kernel_scale;
  const Eigen::RowVectorXd sv_sq = support_vectors.rowwise().squaredNorm().transpose();
  // Rows per block: keep the n_block x n_sv distance tile near 4 MB.
  const Index block = std::max<Index>(16, std::min<Index>(1024, (1 << 19) / support_vectors.rows()));
  const Index n_blocks = (n + block - 1) / block;

  auto run = [&](Index first_block, Index last_block) {
    Eigen::MatrixXd d2;
    for (Index b = first_block; b < last_block; ++b) {
      const Index r0 = b * block, nr = std::min(block, n - r0);
      const auto xb = X.middleRows(r0, nr);
      d2.noalias() = xb * support_vectors.transpose();
      const Eigen::VectorXd x_sq = xb.rowwise().squaredNorm();
      // ||x - sv||^2 = ||x||^2 + ||sv||^2 - 2 x.sv, clamped at 0 against cancellation.
      d2 = ((-2.0 * d2).colwise() + x_sq).rowwise() + sv_sq;
      out.segment(r0, nr).noalias() =
          (-gamma * d2.array().max(0.0)).exp().matrix() * coef;
    }
  };

  int threads = n_threads;
  if (threads <= 0) threads = static_cast<int>(std::min(8u, std::max(1u, std::thread::hardware_concurrency())));
  threads = static_cast<int>(std::min<Index>(threads, n_blocks));
  if (threads <= 1) {
    run(0, n_blocks);
  } else {
    std::vector<std::thread> pool;
    const Index per = (n_blocks + threads - 1) / threads;
    for (int t = 0; t < threads; ++t) {
      const Index b0 = t * per, b1 = std::min(n_blocks, b0 + per);
      if (b0 < b1) pool.emplace_back(run, b0, b1);
    }
    for (auto& th : pool) th.join();
  }
  return out;
}

Eigen::VectorXd OneClassSvmModel::score_samples(const Eigen::Ref<const RowMatrixXd>& X) const {
  return gaussian_kernel_expansion(support_vectors, dual_coef, kernel_scale, X, 1);
}

Eigen::VectorXd OneClassSvmModel::decision_function(const Eigen::Ref<const RowMatrixXd>& X) const {
  return (score_samples(X).array() - rho).matrix();
}

}  // namespace mpmpp
