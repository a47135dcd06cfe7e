#pragma once
// Resampling of FIR coefficient vectors (paper Section 4.2).
//
// The few process-model estimates of the training windows (one row per window, one column per
// impulse-response coefficient g_0..g_m, eq 21) are summarised by a per-coefficient mean mu_i and
// sample standard deviation sigma_i; synthetic models are drawn from independent Gaussians
// N(mu_i, (alpha sigma_i)^2). alpha > 1 widens the density because a handful of windows
// under-estimates the spread (the paper's "conservative PDF"); the paper's guideline is a large
// alpha for few windows and a small one for many.
//
// Random numbers: std::mt19937_64 (its output sequence is fixed by the C++ standard) turned into
// uniforms on (-1, 1) with 53 random bits and into normals by Marsaglia's polar method (only
// sqrt and log, no trigonometry). Draws fill the output row by row. The same seed gives the same
// draws on every run and, up to the platform's log() rounding, on every platform.
#include <Eigen/Dense>
#include <cstdint>

#include "mpmpp/eigen_types.hpp"

namespace mpmpp {

struct CoefficientStatistics {
  Eigen::VectorXd mean;  // mu_i, sample mean over windows
  Eigen::VectorXd std;   // sigma_i, sample standard deviation (divisor N_k - 1)
};

// Per-column mean and sample standard deviation of `features` (N_k x m, N_k >= 2, finite).
CoefficientStatistics coefficient_statistics(const Eigen::Ref<const RowMatrixXd>& features);

// n x m matrix of independent draws, column i ~ N(mean_i, (alpha std_i)^2). alpha >= 0.
RowMatrixXd draw_gaussian_models(const Eigen::Ref<const Eigen::VectorXd>& mean,
                                 const Eigen::Ref<const Eigen::VectorXd>& std, int n, double alpha,
                                 std::uint64_t seed);

// n x m matrix of correlated draws, row ~ N(mean, alpha^2 covariance): mean + alpha L v with
// covariance = L L' (Cholesky; InputError when it is not positive definite) and v drawn from the
// same normal stream as draw_gaussian_models.
RowMatrixXd draw_correlated_gaussian_models(const Eigen::Ref<const Eigen::VectorXd>& mean,
                                            const Eigen::Ref<const Eigen::MatrixXd>& covariance,
                                            int n, double alpha, std::uint64_t seed);

// Sample covariance (divisor N_k - 1) of the rows of `features` (N_k >= 2, finite).
Eigen::MatrixXd coefficient_covariance(const Eigen::Ref<const RowMatrixXd>& features);

// The enlarged training set. correlated = false: the paper's independent per-coefficient
// Gaussians (coefficient_statistics + draw_gaussian_models). correlated = true (mpmpp's
// extension): one multivariate Gaussian with the coefficients' sample covariance. Why: under
// feedback the inputs are strongly autocorrelated, so neighbouring FIR coefficients of one window
// are estimated with a strong negative correlation (their sum, the gain, is far more precise than
// either); independent draws lose that and fill a box in which a doubled gain still fits.
RowMatrixXd resample(const Eigen::Ref<const RowMatrixXd>& features, int n, double alpha = 1.5,
                     std::uint64_t seed = 0, bool correlated = false);

}  // namespace mpmpp
