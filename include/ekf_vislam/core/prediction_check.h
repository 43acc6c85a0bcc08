// The frame's check of the prediction: when most re-observed landmarks fail the gate together,
// the prediction is what is wrong (a twist sample worse than its noise model, a twist noise not
// yet estimated), not the observations. The pose's process noise since the last update is then
// widened, by the one of a few factors that explains the frame's innovations best. No ROS.
#pragma once

#include "ekf_vislam/core/types.h"

#include <Eigen/Core>

#include <vector>

namespace ekf_vislam {

/// One re-observed landmark's view of the prediction.
struct PredictionCheckInput {
  Eigen::VectorXd residual;           ///< r
  Eigen::MatrixXd innovation_cov;     ///< S = H Sigma H^T + R (r x r)
  Eigen::MatrixXd noise_sensitivity;  ///< B (r x 6): the residual's Jacobian with respect to the
                                      ///< pose's process noise (H D, D the noise's map)
};

struct PredictionCheckOptions {
  double gate_threshold = 0.0;  ///< chi-square quantile of one observation: the gate
  /// Each observation's share of the likelihood is capped at this d2 (chi-square 0.9999 of one
  /// observation): a gross outlier counts the same whatever the factor.
  double likelihood_cap = 0.0;
  /// At least this many observations, and more than half of them gated, before the prediction
  /// is suspected: a majority of independent tracks does not fail together by chance.
  int min_observations = 8;
  /// The widening factors tried on the process noise (the noise's variance, so the sigmas widen
  /// by their square roots: 2, 4, 8, 16, 32).
  std::vector<double> factors = {4.0, 16.0, 64.0, 256.0, 1024.0};
};

/// The rule that suspects the prediction: at least options.min_observations, more than half of
/// them gated.
inline bool predictionSuspected(int gated, int observations,
                                const PredictionCheckOptions& options) {
  return observations >= options.min_observations && 2 * gated > observations;
}

/// Observations beyond the gate when the pose's process noise Q is taken `factor` times: each
/// innovation covariance becomes S + (factor - 1) B Q B^T.
int gatedWithWidenedNoise(const std::vector<PredictionCheckInput>& observations,
                          const Matrix6d& process_noise, double factor, double gate_threshold);

/// Sum over the observations of min(d2, cap) + log det S with the process noise taken `factor`
/// times: the negative log-likelihood of the innovations (up to a constant), each observation's
/// share capped so that outliers do not choose the factor.
double cappedNegativeLogLikelihood(const std::vector<PredictionCheckInput>& observations,
                                   const Matrix6d& process_noise, double factor, double cap);

/// The factor by which the pose's process noise since the last update is to be widened: 1 when
/// half of the observations or fewer are gated (or too few to say, or no process noise), else
/// the one of 1 and options.factors whose capped likelihood explains the innovations best
/// (1 when no widening does: the observations disagree among themselves, not with the
/// prediction; left to the gate and the health checks).
double predictionNoiseFactor(const std::vector<PredictionCheckInput>& observations,
                             const Matrix6d& process_noise, const PredictionCheckOptions& options);

}  // namespace ekf_vislam
