#pragma once
// Held-out gain of a candidate term in one output's one-step error when the AR noise
// correction is refitted together with it, for every onset of a grid (the actuator
// candidates of `diagnose`).
//
// With e the nominal one-step error and psi a candidate's H^-1-filtered contribution from
// onset k on, the candidate's error is x_k = e - 1[t >= k] psi and its AR(p) correction is the
// least-squares fit of x_k on its own p lags. All the fit and its error need is the lag Gram
// matrix M_k = sum_t z_t z_t' of z_t = (x_t, ..., x_{t-p}) on a fold's rows:
//   M_k = M^e + sum_{t >= k} (z^psi z^psi' - z^e z^psi' - z^psi z^e'),
// a suffix sum over onset blocks (the indicator is applied to the whole lag vector at t: exact
// except for the p rows after k). The AR fitted on one fold's M_k is scored on the other's.
#include <Eigen/Dense>
#include <vector>

namespace mpmpp {

// Per onset (rows) and training fold (columns): the in-fold statistic
// n_f log(SSE_nominal / SSE_candidate) of the AR fitted on fold f, and the held-out statistic
// n_{1-f} log(SSE_nominal / SSE_candidate) of that AR on the other fold (chi-square scale).
// A candidate whose fit is degenerate at an onset (a singular lag Gram matrix) scores -inf, and
// so does every candidate when the nominal error cannot be fitted on a fold (too few rows).
struct OnsetGains {
  Eigen::MatrixXd in_fold;   // (onsets, 2)
  Eigen::MatrixXd held_out;  // (onsets, 2)
};

class RefittedNoise {
 public:
  // e: the nominal one-step error (finite); fold0, fold1: the two folds' row weights (a row
  // belongs to at most one fold); onsets: increasing sample indices; order: the AR order p.
  RefittedNoise(const Eigen::Ref<const Eigen::VectorXd>& e,
                const Eigen::Ref<const Eigen::VectorXd>& fold0,
                const Eigen::Ref<const Eigen::VectorXd>& fold1,
                const std::vector<Eigen::Index>& onsets, int order);

  // The statistics of the candidate term psi (H^-1-filtered, on e's rows) from each onset on.
  OnsetGains gains(const Eigen::Ref<const Eigen::VectorXd>& psi) const;

 private:
  // `gains` with lag matrices of size P1 = order + 1 fixed at compile time (or Eigen::Dynamic).
  template <int P1>
  OnsetGains scores(const Eigen::Ref<const Eigen::VectorXd>& psi) const;

  Eigen::VectorXd e_, weight_;
  std::vector<int> fold_;  // per row: 0, 1, or -1 (in neither fold)
  std::vector<Eigen::Index> onsets_;
  int order_;
  Eigen::MatrixXd gram_[2];      // M^e per fold
  double rows_[2] = {0.0, 0.0};  // weight sums
  double nominal_fit_[2] = {0.0, 0.0}, nominal_held_[2] = {0.0, 0.0};
  bool degenerate_ = false;  // the nominal AR cannot be fitted on a fold
};

}  // namespace mpmpp
