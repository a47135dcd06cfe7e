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

// The dot products and exponentials behind every kernel value (dot_tile, gaussian_column,
// gaussian_sum) are compiled for three x86-64 levels (AVX-512, AVX2+FMA, baseline SSE2) and
// picked at load time by the CPU (GCC function multi-versioning), since the package is built
// without -march=native. -DMPMPP_NO_CPU_CLONES builds the baseline only.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(MPMPP_NO_CPU_CLONES)
#define MPMPP_CPU_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MPMPP_CPU_CLONES
#endif

// Points packed in panels of kPanel for the dot-product kernel: feature k of point j lives at
// data[(j / kPanel) * kPanel * m + k * kPanel + j % kPanel], so a sweep over the features of one
// panel reads memory contiguously (the layout a GEMM packs into). Padding points are zero.
constexpr int kPanel = 8;

class PackedPoints {
 public:
  explicit PackedPoints(const Eigen::Ref<const RowMatrixXd>& X)
      : n_(static_cast<int>(X.rows())),
        m_(static_cast<int>(X.cols())),
        n_pad_((n_ + kPanel - 1) / kPanel * kPanel),
        data_(static_cast<size_t>(n_pad_) * m_, 0.0) {
    for (int j = 0; j < n_; ++j) {
      const double* row = X.row(j).data();
      double* dst = data_.data() + offset(j, 0);
      for (int k = 0; k < m_; ++k) dst[static_cast<size_t>(k) * kPanel] = row[k];
    }
  }
  int size() const { return n_; }
  int padded_size() const { return n_pad_; }
  int features() const { return m_; }
  const double* data() const { return data_.data(); }
  double& at(int j, int k) { return data_[offset(j, k)]; }
  double at(int j, int k) const { return data_[offset(j, k)]; }
  void swap_points(int i, int j) {
    for (int k = 0; k < m_; ++k) std::swap(at(i, k), at(j, k));
  }

 private:
  size_t offset(int j, int k) const {
    return static_cast<size_t>(j / kPanel) * kPanel * m_ + static_cast<size_t>(k) * kPanel +
           j % kPanel;
  }
  int n_, m_, n_pad_;
  std::vector<double> data_;
};

// out[p * ldo + j - j_first] = sum_k q[p * m + k] x_jk   for p < n_q and the packed points j
// in panels [panel0, panel1), j_first = panel0 * kPanel. q: n_q query points, row-major. Every sum
// runs over k in increasing order, as a plain dot product does. Register tile of 4 queries x 8
// points in 4-wide vectors (GCC vector extensions, lowered to each clone's ISA): per feature, two
// contiguous loads feed 32 multiply-adds.
typedef double Vec4 __attribute__((vector_size(32)));
#define MPMPP_LOAD4(v, ptr) __builtin_memcpy(&(v), (ptr), sizeof(Vec4))
#define MPMPP_STORE4(ptr, v) __builtin_memcpy((ptr), &(v), sizeof(Vec4))

MPMPP_CPU_CLONES
void dot_tile(const double* q, int n_q, int m, const double* packed, int panel0, int panel1,
              double* out, Index ldo) {
  static_assert(kPanel == 8, "the register tile below spans one panel");
  for (int p0 = 0; p0 < n_q; p0 += 4) {
    const int nq = std::min(4, n_q - p0);
    const double* q0 = q + static_cast<Index>(p0) * m;
    double* o = out + p0 * ldo;
    if (nq < 4) {
      // Fewer than 4 queries (one kernel column): 4 panels at a time, so 8 independent
      // accumulator chains hide the multiply-add latency.
      for (int p = 0; p < nq; ++p) {
        const double* qp = q0 + p * m;
        double* op = o + p * ldo;
        int panel = panel0;
        for (; panel + 4 <= panel1; panel += 4) {
          const double* c = packed + static_cast<Index>(panel) * kPanel * m;
          const Index stride = static_cast<Index>(kPanel) * m;
          Vec4 a00 = {}, a01 = {}, a10 = {}, a11 = {}, a20 = {}, a21 = {}, a30 = {}, a31 = {};
          for (int k = 0; k < m; ++k, c += kPanel) {
            Vec4 c00, c01, c10, c11, c20, c21, c30, c31;
            MPMPP_LOAD4(c00, c);
            MPMPP_LOAD4(c01, c + 4);
            MPMPP_LOAD4(c10, c + stride);
            MPMPP_LOAD4(c11, c + stride + 4);
            MPMPP_LOAD4(c20, c + 2 * stride);
            MPMPP_LOAD4(c21, c + 2 * stride + 4);
            MPMPP_LOAD4(c30, c + 3 * stride);
            MPMPP_LOAD4(c31, c + 3 * stride + 4);
            const double b = qp[k];
            a00 += c00 * b;
            a01 += c01 * b;
            a10 += c10 * b;
            a11 += c11 * b;
            a20 += c20 * b;
            a21 += c21 * b;
            a30 += c30 * b;
            a31 += c31 * b;
          }
          double* dst = op + static_cast<Index>(panel - panel0) * kPanel;
          MPMPP_STORE4(dst, a00);
          MPMPP_STORE4(dst + 4, a01);
          MPMPP_STORE4(dst + 8, a10);
          MPMPP_STORE4(dst + 12, a11);
          MPMPP_STORE4(dst + 16, a20);
          MPMPP_STORE4(dst + 20, a21);
          MPMPP_STORE4(dst + 24, a30);
          MPMPP_STORE4(dst + 28, a31);
        }
        for (; panel < panel1; ++panel) {
          const double* c = packed + static_cast<Index>(panel) * kPanel * m;
          Vec4 a0 = {}, a1 = {};
          for (int k = 0; k < m; ++k, c += kPanel) {
            Vec4 c0, c1;
            MPMPP_LOAD4(c0, c);
            MPMPP_LOAD4(c1, c + 4);
            a0 += c0 * qp[k];
            a1 += c1 * qp[k];
          }
          double* dst = op + static_cast<Index>(panel - panel0) * kPanel;
          MPMPP_STORE4(dst, a0);
          MPMPP_STORE4(dst + 4, a1);
        }
      }
      continue;
    }
    for (int panel = panel0; panel < panel1; ++panel) {
      const double* c = packed + static_cast<Index>(panel) * kPanel * m;
      const Index j0 = static_cast<Index>(panel - panel0) * kPanel;
      Vec4 a00 = {}, a01 = {}, a10 = {}, a11 = {}, a20 = {}, a21 = {}, a30 = {}, a31 = {};
      for (int k = 0; k < m; ++k, c += kPanel) {
        Vec4 c0, c1;
        MPMPP_LOAD4(c0, c);
        MPMPP_LOAD4(c1, c + 4);
        const double b0 = q0[k], b1 = q0[m + k], b2 = q0[2 * m + k], b3 = q0[3 * m + k];
        a00 += c0 * b0;
        a01 += c1 * b0;
        a10 += c0 * b1;
        a11 += c1 * b1;
        a20 += c0 * b2;
        a21 += c1 * b2;
        a30 += c0 * b3;
        a31 += c1 * b3;
      }
      MPMPP_STORE4(o + j0, a00);
      MPMPP_STORE4(o + j0 + 4, a01);
      MPMPP_STORE4(o + ldo + j0, a10);
      MPMPP_STORE4(o + ldo + j0 + 4, a11);
      MPMPP_STORE4(o + 2 * ldo + j0, a20);
      MPMPP_STORE4(o + 2 * ldo + j0 + 4, a21);
      MPMPP_STORE4(o + 3 * ldo + j0, a30);
      MPMPP_STORE4(o + 3 * ldo + j0 + 4, a31);
    }
  }
}

// exp(x) on 4 lanes, within 1 ulp of the correctly rounded value for x in [-708, 709] (inputs
// are clamped to that range; below it the result is 3e-308 instead of a denormal or 0, which
// rounds to the same single-precision 0 and is negligible in a decision sum). Cody-Waite
// reduction x = n ln2 + r, |r| <= ln2 / 2, and the degree-11 Taylor polynomial of e^r (truncation
// error below 1e-21). Inlined into each CPU clone.
typedef long long Vec4i __attribute__((vector_size(32)));
typedef float Vec4f __attribute__((vector_size(16)));

__attribute__((always_inline)) inline void vexp(Vec4& x) {
  const Vec4 lo = {-708.0, -708.0, -708.0, -708.0}, hi = {709.0, 709.0, 709.0, 709.0};
  x = x < lo ? lo : x;
  x = x > hi ? hi : x;
  const double shifter = 0x1.8p52;  // adding it rounds to an integer held in the low bits
  const Vec4 t = x * 1.4426950408889634 + shifter;
  const Vec4 n = t - shifter;
  const Vec4 r = (x - n * 6.93147180369123816490e-01) - n * 1.90821492927058770002e-10;
  Vec4 p = r * (1.0 / 39916800) + 1.0 / 3628800;
  p = p * r + 1.0 / 362880;
  p = p * r + 1.0 / 40320;
  p = p * r + 1.0 / 5040;
  p = p * r + 1.0 / 720;
  p = p * r + 1.0 / 120;
  p = p * r + 1.0 / 24;
  p = p * r + 1.0 / 6;
  p = p * r + 0.5;
  p = p * r + 1.0;
  p = p * r + 1.0;
  Vec4i bits;
  __builtin_memcpy(&bits, &t, sizeof bits);
  long long shifter_bits;
  __builtin_memcpy(&shifter_bits, &shifter, sizeof shifter_bits);
  bits = (bits - shifter_bits + 1023) << 52;  // 2^n
  Vec4 scale;
  __builtin_memcpy(&scale, &bits, sizeof scale);
  x = p * scale;
}

// out[j] = exp(-gamma (sq_i + sq[j] - 2 dots[j])) rounded to single precision, j < n: one
// kernel column from its dot products, the expression of libsvm's RBF kernel.
MPMPP_CPU_CLONES
void gaussian_column(const double* dots, const double* sq, double sq_i, double gamma, int n,
                     float* out) {
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    Vec4 d, q;
    MPMPP_LOAD4(d, dots + j);
    MPMPP_LOAD4(q, sq + j);
    Vec4 v = -gamma * ((sq_i + q) - 2 * d);
    vexp(v);
    const Vec4f f = __builtin_convertvector(v, Vec4f);  // round to nearest, as static_cast
    __builtin_memcpy(out + j, &f, sizeof f);
  }
  for (; j < n; ++j) out[j] = static_cast<float>(std::exp(-gamma * (sq_i + sq[j] - 2 * dots[j])));
}

// sum_j coef[j] exp(-gamma max(0, x_sq + sq[j] - 2 dots[j])), j < n: a decision-function term.
MPMPP_CPU_CLONES
double gaussian_sum(const double* dots, const double* sq, const double* coef, double x_sq,
                    double gamma, int n) {
  Vec4 acc = {};
  const Vec4 zero = {};
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    Vec4 d, q, c;
    MPMPP_LOAD4(d, dots + j);
    MPMPP_LOAD4(q, sq + j);
    MPMPP_LOAD4(c, coef + j);
    Vec4 d2 = (x_sq + q) - 2 * d;
    d2 = d2 < zero ? zero : d2;  // clamp round-off below 0
    Vec4 v = -gamma * d2;
    vexp(v);
    acc += c * v;
  }
  double sum = (acc[0] + acc[1]) + (acc[2] + acc[3]);
  for (; j < n; ++j) sum += coef[j] * std::exp(-gamma * std::max(0.0, x_sq + sq[j] - 2 * dots[j]));
  return sum;
}

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

// Gaussian kernel matrix Q_ij = exp(-gamma ||x_i - x_j||^2), gamma = 1/c (eq 15), seen through
// the solver's current permutation of the training points (shrinking moves inactive points to
// the end). Columns are computed on demand with one matrix-vector product, stored in single
// precision (as libsvm does, which halves memory and keeps our iterates on libsvm's path) and
// kept in a least-recently-used cache bounded in bytes. Q_ii = 1 exactly for this kernel.
class KernelColumns {
 public:
  KernelColumns(const Eigen::Ref<const RowMatrixXd>& X, double gamma, double cache_mb)
      : x_(X),
        sq_norm_(X.rowwise().squaredNorm()),
        gamma_(gamma),
        l_(static_cast<int>(X.rows())),
        columns_(static_cast<size_t>(l_) + 1),
        dots_(x_.padded_size()),
        point_(X.cols()) {
    const double bytes = cache_mb * 1024.0 * 1024.0;
    const double floats = bytes / sizeof(float) - 8.0 * l_;  // minus bookkeeping, like libsvm
    // At least two full columns, so fetching Q_j never evicts the Q_i fetched just before it.
    budget_ = std::max<std::int64_t>(static_cast<std::int64_t>(std::min(floats, 9.0e18)),
                                     2 * static_cast<std::int64_t>(l_));
    sentinel().prev = sentinel().next = l_;
  }

  int size() const { return l_; }

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

  // Length of the cached part of column i (0 when not cached).
  int cached_length(int i) const { return columns_[i].len; }

  // How many columns of length len still fit in the budget without evicting any.
  std::int64_t free_columns(int len) const { return budget_ / std::max(len, 1); }

  // Computes and caches the columns of four uncached points over [0, len) in one pass over the
  // data, the last of them becoming the most recently used. One column alone is bounded by the
  // memory traffic of reading every point (the dots of one query do one multiply-add per load);
  // the 4-query tile of dot_tile shares each load between four columns, so the four cost about
  // as much as one. Values are identical to column()'s (same dot_tile sums, same expression).
  void compute_four(const int* points, int len) {
    const int m = x_.features();
    const int n_panels = (len + kPanel - 1) / kPanel, ld = n_panels * kPanel;
    queries_.resize(4 * m);
    four_dots_.resize(static_cast<size_t>(4) * ld);
    for (int p = 0; p < 4; ++p)
      for (int k = 0; k < m; ++k) queries_[p * m + k] = x_.at(points[p], k);
    dot_tile(queries_.data(), 4, m, x_.data(), 0, n_panels, four_dots_.data(), ld);
    for (int p = 0; p < 4; ++p) {
      const int i = points[p];
      Column& h = columns_[i];
      while (budget_ < len) evict(sentinel().next);
      h.data.resize(len);
      budget_ -= len;
      gaussian_column(four_dots_.data() + static_cast<size_t>(p) * ld, sq_norm_.data(), sq_norm_[i],
                      gamma_, len, h.data.data());
      h.len = len;
      link_last(i);
    }
  }

  // Columns c0 .. c0 + nc - 1 over all l points (before any shrinking), by one matrix product.
  void full_columns(int c0, int nc, Eigen::MatrixXf& out) const {
    const int m = x_.features();
    RowMatrixXd queries(nc, m);
    for (int p = 0; p < nc; ++p)
      for (int k = 0; k < m; ++k) queries(p, k) = x_.at(c0 + p, k);
    const int ld = x_.padded_size();
    RowMatrixXd tile(nc, ld);  // row p = dots of point c0 + p with all points
    // ~200 kB of points at a time, so they stay in cache while every query passes over them.
    const int chunk = std::max(1, 25600 / (kPanel * m));
    for (int p0 = 0; p0 < ld / kPanel; p0 += chunk)
      dot_tile(queries.data(), nc, m, x_.data(), p0, std::min(ld / kPanel, p0 + chunk),
               tile.data() + p0 * kPanel, ld);
    out.resize(l_, nc);
    for (int k = 0; k < nc; ++k)
      gaussian_column(tile.row(k).data(), sq_norm_.data(), sq_norm_[c0 + k], gamma_, l_,
                      out.col(k).data());
  }

  // Cache a full column computed elsewhere (evicting the least recently used ones if needed).
  void insert(int i, const float* data) {
    Column& h = columns_[i];
    if (h.len > 0) unlink(i);
    const std::int64_t more = l_ - h.len;
    if (more > 0) {
      while (budget_ < more) evict(sentinel().next);
      budget_ -= more;
    }
    h.data.assign(data, data + l_);
    h.len = l_;
    link_last(i);
  }

  // Exchange points i and j in the solver order; cached columns follow (or are dropped when
  // they cover only one of the two positions).
  void swap_index(int i, int j) {
    if (i == j) return;
    x_.swap_points(i, j);
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
    for (int k = 0; k < x_.features(); ++k) point_[k] = x_.at(i, k);
    dot_tile(point_.data(), 1, x_.features(), x_.data(), start / kPanel,
             (len + kPanel - 1) / kPanel, dots_.data(), 0);
    // Same expression as libsvm's RBF kernel: exp(-gamma (|x_i|^2 + |x_j|^2 - 2 x_i.x_j)).
    gaussian_column(dots_.data() + start % kPanel, sq_norm_.data() + start, sq_norm_[i], gamma_,
                    len - start, out + start);
  }

  PackedPoints x_;
  Eigen::VectorXd sq_norm_;
  double gamma_;
  int l_;
  std::vector<Column> columns_;  // l_ heads plus the LRU list's sentinel at index l_
  std::int64_t budget_;          // floats still available
  Eigen::VectorXd dots_, point_;
  std::vector<double> queries_, four_dots_;  // compute_four's buffers
};

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

// A sum of x * 0 is NaN exactly when some x is NaN or infinite; Eigen's allFinite() is a
// comparison per element, which shows in the fit time of small problems.
MPMPP_CPU_CLONES
bool all_finite(const double* x, Index n_rows, Index n_cols, Index row_stride) {
  Vec4 acc = {};
  for (Index r = 0; r < n_rows; ++r, x += row_stride) {
    Index k = 0;
    for (; k + 4 <= n_cols; k += 4) {
      Vec4 v;
      MPMPP_LOAD4(v, x + k);
      acc += v * 0.0;
    }
    for (; k < n_cols; ++k) acc[0] += x[k] * 0.0;
  }
  const double sum = (acc[0] + acc[1]) + (acc[2] + acc[3]);
  return sum == sum;
}

void require_finite(const Eigen::Ref<const RowMatrixXd>& X, const char* name) {
  if (!all_finite(X.data(), X.rows(), X.cols(), X.outerStride()))
    throw InputError(std::string(name) + ": contains NaN or infinite values");
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
  const PackedPoints sv(support_vectors);
  const Eigen::VectorXd sv_sq = support_vectors.rowwise().squaredNorm();
  const int m = static_cast<int>(X.cols());
  const int n_panels = sv.padded_size() / kPanel;
  // Tiles of kRows test points x kPanels * 8 support vectors (256 kB, cache resident).
  constexpr Index kRows = 64;
  constexpr int kPanels = 64;
  const Index n_blocks = (n + kRows - 1) / kRows;

  auto run = [&](Index first_block, Index last_block) {
    std::vector<double> tile(static_cast<size_t>(kRows) * kPanels * kPanel);
    RowMatrixXd xb;
    for (Index b = first_block; b < last_block; ++b) {
      const Index r0 = b * kRows, nr = std::min(kRows, n - r0);
      xb = X.middleRows(r0, nr);  // contiguous rows for dot_tile
      for (int c0 = 0; c0 < n_panels; c0 += kPanels) {
        const int c1 = std::min(n_panels, c0 + kPanels);
        const int j0 = c0 * kPanel, nj = std::min(c1 * kPanel, sv.size()) - j0;
        const Index ld = kPanels * kPanel;
        dot_tile(xb.data(), static_cast<int>(nr), m, sv.data(), c0, c1, tile.data(), ld);
        for (Index r = 0; r < nr; ++r) {
          const double x_sq = xb.row(r).squaredNorm();
          // ||x - sv||^2 = ||x||^2 + ||sv||^2 - 2 x.sv (clamped at 0 against cancellation).
          out[r0 + r] += gaussian_sum(tile.data() + r * ld, sv_sq.data() + j0, coef.data() + j0,
                                      x_sq, gamma, nj);
        }
      }
    }
  };

  int threads = n_threads;
  if (threads <= 0)
    threads = static_cast<int>(std::min(8u, std::max(1u, std::thread::hardware_concurrency())));
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
