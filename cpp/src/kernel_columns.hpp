#pragma once
// Internal to the one-class SVM: the training's kernel matrix, column by column, cached.
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <vector>

#include "gaussian_kernel.hpp"
#include "mpmpp/eigen_types.hpp"

namespace mpmpp::detail {

// Gaussian kernel matrix Q_ij = exp(-gamma ||x_i - x_j||^2), gamma = 1/c (eq 15), seen through
// the solver's current permutation of the training points (shrinking moves inactive points to
// the end). Columns are computed on demand with one matrix-vector product, stored in single
// precision (as libsvm does, which halves memory and keeps our iterates on libsvm's path) and
// kept in a least-recently-used cache bounded in bytes. Q_ii = 1 exactly for this kernel.
class KernelColumns {
 public:
  KernelColumns(const Eigen::Ref<const RowMatrixXd>& X, double gamma, double cache_mb);

  int size() const { return l_; }

  // Q_i[0, len): the first len entries of column i in the current order.
  const float* column(int i, int len);

  // Length of the cached part of column i (0 when not cached).
  int cached_length(int i) const { return columns_[i].len; }

  // How many columns of length len still fit in the budget without evicting any.
  std::int64_t free_columns(int len) const { return budget_ / std::max(len, 1); }

  // Computes and caches the columns of four uncached points over [0, len) in one pass over the
  // data, the last of them becoming the most recently used. One column alone is bounded by the
  // memory traffic of reading every point (the dots of one query do one multiply-add per load);
  // the 4-query tile of dot_tile shares each load between four columns, so the four cost about
  // as much as one. Values are identical to column()'s (same dot_tile sums, same expression).
  void compute_four(const int* points, int len);

  // Columns c0 .. c0 + nc - 1 over all l points (before any shrinking), by one matrix product.
  void full_columns(int c0, int nc, Eigen::MatrixXf& out) const;

  // Cache a full column computed elsewhere (evicting the least recently used ones if needed).
  void insert(int i, const float* data);

  // Exchange points i and j in the solver order; cached columns follow (or are dropped when
  // they cover only one of the two positions).
  void swap_index(int i, int j);

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

  void fill(int i, int start, int len, float* out);

  PackedPoints x_;
  Eigen::VectorXd sq_norm_;
  double gamma_;
  int l_;
  std::vector<Column> columns_;  // l_ heads plus the LRU list's sentinel at index l_
  std::int64_t budget_;          // floats still available
  Eigen::VectorXd dots_, point_;
  std::vector<double> queries_, four_dots_;  // compute_four's buffers
};

}  // namespace mpmpp::detail
