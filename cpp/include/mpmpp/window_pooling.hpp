#pragma once
// Pooling the residual regression's estimates of disjoint windows (DetectorConfig::pooled_windows).
//
// One 2 h window resolves a 0.5-2x change of a channel only when the loop is excited in it
// (a setpoint step, a large disturbance): on the tuning families most missed changes never
// reach the window level in any window (docs/families.md "Where the missed detections go").
// A longer window adds evidence but also resolves the small bias a disturbance change leaves
// through the whitening (paper SISO scenario, its noise change: an MPM alarm in 4-9 of 40 runs
// with 4 h windows against 1 with 2 h). Pooling disjoint windows adds the evidence and keeps
// each window's own A(q), trend, breaks and outlier rows: with no change, windows that share no
// sample give independent estimates x_i ~ N(beta, C_i), so their precision-weighted mean
//   x = C (sum_i C_i^+ x_i),  C = (sum_i C_i^+)^+
// has covariance C and the Wald test of ChannelScorer applies to (x, C) unchanged.
// Pseudo-inverses are taken in correlation form (each coefficient scaled by the root of its
// mean variance over the windows) with the Wald test's relative rank cut, so a direction that
// no window resolves drops out instead of dominating.
#include <Eigen/Dense>
#include <vector>

namespace mpmpp {

struct PooledEstimate {
  Eigen::VectorXd mean;
  Eigen::MatrixXd covariance;
};

// estimates[i] with covariances[i] (all d and d x d, finite); InputError on mismatched sizes
// or an empty list. One window returns itself.
PooledEstimate pool_estimates(const std::vector<Eigen::VectorXd>& estimates,
                              const std::vector<Eigen::MatrixXd>& covariances);

}  // namespace mpmpp
