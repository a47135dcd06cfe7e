#pragma once
// Internal to the one-class SVM: the Gaussian kernel k(x, y) = exp(-gamma ||x - y||^2) of eq 15
// (gamma = 1/c) evaluated as ||x||^2 + ||y||^2 - 2 x.y, with the dot products of many points at
// once from points packed in panels (dot_tile) and the exponentials four lanes at a time. Used by
// the training's kernel columns (kernel_columns.hpp) and by every decision function
// (gaussian_kernel_expansion).
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mpmpp/eigen_types.hpp"

namespace mpmpp::detail {

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
void dot_tile(const double* q, int n_q, int m, const double* packed, int panel0, int panel1,
              double* out, Eigen::Index ldo);

// out[j] = exp(-gamma (sq_i + sq[j] - 2 dots[j])) rounded to single precision, j < n: one
// kernel column from its dot products, the expression of libsvm's RBF kernel.
void gaussian_column(const double* dots, const double* sq, double sq_i, double gamma, int n,
                     float* out);

// sum_j coef[j] exp(-gamma max(0, x_sq + sq[j] - 2 dots[j])), j < n: a decision-function term.
double gaussian_sum(const double* dots, const double* sq, const double* coef, double x_sq,
                    double gamma, int n);

// InputError unless every entry of X is finite ("<name>: contains NaN or infinite values").
void require_finite(const Eigen::Ref<const RowMatrixXd>& X, const char* name);

// InputError unless the kernel scale c is a finite number > 0.
void check_kernel_scale(double c);

}  // namespace mpmpp::detail
