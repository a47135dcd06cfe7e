#include "kernel_columns.hpp"

#include <algorithm>

namespace mpmpp::detail {

KernelColumns::KernelColumns(const Eigen::Ref<const RowMatrixXd>& X, double gamma, double cache_mb)
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

const float* KernelColumns::column(int i, int len) {
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

void KernelColumns::compute_four(const int* points, int len) {
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

void KernelColumns::full_columns(int c0, int nc, Eigen::MatrixXf& out) const {
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

void KernelColumns::insert(int i, const float* data) {
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

void KernelColumns::swap_index(int i, int j) {
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

void KernelColumns::fill(int i, int start, int len, float* out) {
  for (int k = 0; k < x_.features(); ++k) point_[k] = x_.at(i, k);
  dot_tile(point_.data(), 1, x_.features(), x_.data(), start / kPanel, (len + kPanel - 1) / kPanel,
           dots_.data(), 0);
  // Same expression as libsvm's RBF kernel: exp(-gamma (|x_i|^2 + |x_j|^2 - 2 x_i.x_j)).
  gaussian_column(dots_.data() + start % kPanel, sq_norm_.data() + start, sq_norm_[i], gamma_,
                  len - start, out + start);
}

}  // namespace mpmpp::detail
