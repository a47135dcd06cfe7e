#include "gaussian_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>

#include "mpmpp/error.hpp"
#include "mpmpp/one_class_svm.hpp"
#include "simd4.hpp"

namespace mpmpp {
namespace detail {

using Eigen::Index;

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

}  // namespace detail

Eigen::VectorXd gaussian_kernel_expansion(const Eigen::Ref<const RowMatrixXd>& support_vectors,
                                          const Eigen::Ref<const Eigen::VectorXd>& coef,
                                          double kernel_scale,
                                          const Eigen::Ref<const RowMatrixXd>& X, int n_threads) {
  detail::check_kernel_scale(kernel_scale);
  if (coef.size() != support_vectors.rows())
    throw InputError("coef: length " + std::to_string(coef.size()) + " does not match " +
                     std::to_string(support_vectors.rows()) + " support vectors");
  if (X.cols() != support_vectors.cols())
    throw InputError("X: has " + std::to_string(X.cols()) + " features, the model expects " +
                     std::to_string(support_vectors.cols()));
  detail::require_finite(X, "X");
  const Eigen::Index n = X.rows();
  Eigen::VectorXd out = Eigen::VectorXd::Zero(n);
  if (n == 0 || support_vectors.rows() == 0) return out;

  const double gamma = 1.0 / kernel_scale;
  const detail::PackedPoints sv(support_vectors);
  const Eigen::VectorXd sv_sq = support_vectors.rowwise().squaredNorm();
  const int m = static_cast<int>(X.cols());
  const int n_panels = sv.padded_size() / detail::kPanel;
  // Tiles of kRows test points x kPanels * 8 support vectors (256 kB, cache resident).
  constexpr Eigen::Index kRows = 64;
  constexpr int kPanels = 64;
  const Eigen::Index n_blocks = (n + kRows - 1) / kRows;

  auto run = [&](Eigen::Index first_block, Eigen::Index last_block) {
    std::vector<double> tile(static_cast<size_t>(kRows) * kPanels * detail::kPanel);
    RowMatrixXd xb;
    for (Eigen::Index b = first_block; b < last_block; ++b) {
      const Eigen::Index r0 = b * kRows, nr = std::min(kRows, n - r0);
      xb = X.middleRows(r0, nr);  // contiguous rows for dot_tile
      for (int c0 = 0; c0 < n_panels; c0 += kPanels) {
        const int c1 = std::min(n_panels, c0 + kPanels);
        const int j0 = c0 * detail::kPanel, nj = std::min(c1 * detail::kPanel, sv.size()) - j0;
        const Eigen::Index ld = kPanels * detail::kPanel;
        detail::dot_tile(xb.data(), static_cast<int>(nr), m, sv.data(), c0, c1, tile.data(), ld);
        for (Eigen::Index r = 0; r < nr; ++r) {
          const double x_sq = xb.row(r).squaredNorm();
          // ||x - sv||^2 = ||x||^2 + ||sv||^2 - 2 x.sv (clamped at 0 against cancellation).
          out[r0 + r] += detail::gaussian_sum(tile.data() + r * ld, sv_sq.data() + j0,
                                              coef.data() + j0, x_sq, gamma, nj);
        }
      }
    }
  };

  int threads = n_threads;
  if (threads <= 0)
    threads = static_cast<int>(std::min(8u, std::max(1u, std::thread::hardware_concurrency())));
  threads = static_cast<int>(std::min<Eigen::Index>(threads, n_blocks));
  if (threads <= 1) {
    run(0, n_blocks);
  } else {
    std::vector<std::thread> pool;
    const Eigen::Index per = (n_blocks + threads - 1) / threads;
    for (int t = 0; t < threads; ++t) {
      const Eigen::Index b0 = t * per, b1 = std::min(n_blocks, b0 + per);
      if (b0 < b1) pool.emplace_back(run, b0, b1);
    }
    for (auto& th : pool) th.join();
  }
  return out;
}

}  // namespace mpmpp
