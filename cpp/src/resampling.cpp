#include "mpmpp/resampling.hpp"

#include <cmath>
#include <random>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {
namespace {

// Standard normal variates from a 64-bit Mersenne Twister by Marsaglia's polar method; the
// second variate of each accepted pair is kept for the next call.
class NormalStream {
 public:
  explicit NormalStream(std::uint64_t seed) : engine_(seed) {}

  double next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform01() - 1.0;
      v = 2.0 * uniform01() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  // [0, 1) with 53 random bits: exact in double, independent of the library's distributions
  // (whose algorithms the standard leaves to the implementation).
  double uniform01() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace

CoefficientStatistics coefficient_statistics(const Eigen::Ref<const RowMatrixXd>& features) {
  if (features.rows() < 2 || features.cols() < 1)
    throw InputError("features: need at least 2 training windows (rows) and 1 coefficient, got " +
                     std::to_string(features.rows()) + " x " + std::to_string(features.cols()));
  if (!features.allFinite()) throw InputError("features: contains NaN or infinite values");
  CoefficientStatistics s;
  s.mean = features.colwise().mean().transpose();
  const double n_k = static_cast<double>(features.rows());
  s.std =
      ((features.rowwise() - s.mean.transpose()).colwise().squaredNorm().transpose() / (n_k - 1.0))
          .cwiseSqrt();
  return s;
}

RowMatrixXd draw_gaussian_models(const Eigen::Ref<const Eigen::VectorXd>& mean,
                                 const Eigen::Ref<const Eigen::VectorXd>& std, int n, double alpha,
                                 std::uint64_t seed) {
  if (n < 1)
    throw InputError("n: number of synthetic models must be >= 1, got " + std::to_string(n));
  if (!(alpha >= 0) || !std::isfinite(alpha))
    throw InputError("alpha: width factor must be a finite number >= 0, got " +
                     std::to_string(alpha));
  if (mean.size() != std.size() || mean.size() < 1)
    throw InputError("mean/std: need equal, non-zero lengths");
  if (!mean.allFinite() || !std.allFinite() || (std.array() < 0).any())
    throw InputError("mean/std: must be finite with std >= 0");
  const Eigen::VectorXd width = alpha * std;
  NormalStream normal(seed);
  RowMatrixXd draws(n, mean.size());
  for (int r = 0; r < n; ++r)
    for (Eigen::Index c = 0; c < mean.size(); ++c) draws(r, c) = mean[c] + width[c] * normal.next();
  return draws;
}

Eigen::MatrixXd coefficient_covariance(const Eigen::Ref<const RowMatrixXd>& features) {
  const CoefficientStatistics s = coefficient_statistics(features);  // validates the shape
  const RowMatrixXd centred = features.rowwise() - s.mean.transpose();
  return centred.transpose() * centred / static_cast<double>(features.rows() - 1);
}

RowMatrixXd draw_correlated_gaussian_models(const Eigen::Ref<const Eigen::VectorXd>& mean,
                                            const Eigen::Ref<const Eigen::MatrixXd>& covariance,
                                            int n, double alpha, std::uint64_t seed) {
  if (!(alpha >= 0) || !std::isfinite(alpha))
    throw InputError("alpha: width factor must be a finite number >= 0, got " +
                     std::to_string(alpha));
  if (covariance.rows() != mean.size() || covariance.cols() != mean.size() || mean.size() < 1)
    throw InputError("covariance: must be m x m with m = length of mean (>= 1)");
  if (!covariance.allFinite()) throw InputError("covariance: must be finite");
  const Eigen::LLT<Eigen::MatrixXd> llt(covariance);
  // L_ii^2 / S_ii = 1 - R^2 of coefficient i regressed on the earlier ones: below 1e-10 the
  // covariance is singular up to rounding (e.g. fewer windows than coefficients).
  const bool singular =
      llt.info() != Eigen::Success || (llt.matrixL().toDenseMatrix().diagonal().array().square() <=
                                       1e-10 * covariance.diagonal().array())
                                          .any();
  if (singular)
    throw InputError(
        "covariance: not positive definite (a coefficient that never varies, or "
        "fewer training windows than coefficients)");
  // Standard normals from the same stream and in the same order as the independent draws.
  const RowMatrixXd v = draw_gaussian_models(Eigen::VectorXd::Zero(mean.size()),
                                             Eigen::VectorXd::Ones(mean.size()), n, 1.0, seed);
  return (v * (alpha * llt.matrixL().toDenseMatrix()).transpose()).rowwise() + mean.transpose();
}

RowMatrixXd resample(const Eigen::Ref<const RowMatrixXd>& features, int n, double alpha,
                     std::uint64_t seed, bool correlated) {
  const CoefficientStatistics s = coefficient_statistics(features);
  if (correlated)
    return draw_correlated_gaussian_models(s.mean, coefficient_covariance(features), n, alpha,
                                           seed);
  return draw_gaussian_models(s.mean, s.std, n, alpha, seed);
}

}  // namespace mpmpp
