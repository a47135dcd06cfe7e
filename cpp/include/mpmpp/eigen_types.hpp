#pragma once
// Eigen types shared across the library's interfaces.
#include <Eigen/Dense>

namespace mpmpp {

// Row-major so that a row (one window's features, one training model) is contiguous: the SVM
// kernels stream rows, and NumPy's default C order maps onto it without a copy.
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

}  // namespace mpmpp
