// The frame's check of the prediction: when most re-observed landmarks fail the gate together,
// the prediction is what is wrong (a twist sample worse than its noise model, a twist noise not
// yet estimated), not the observations. The pose's process noise since the last update is then
// widened, by the one of a few factors that explains the frame's innovations best, and the frame
// is gated jointly: the pose change the observations share is fitted to them, and each is gated
// on what that leaves of it, so that one error common to all does not gate them all. No ROS.
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
  /// observation): a gross outlier counts the same whatever the factor. An observation beyond
  /// it after the shared error is fitted with the widest factor is left out of that fit.
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
/// innovation covariance becomes S + (factor - 1) B Q B^T (factor 0: N = S - B Q B^T, the
/// observation without the process noise's part).
int gatedWithWidenedNoise(const std::vector<PredictionCheckInput>& observations,
                          const Matrix6d& process_noise, double factor, double gate_threshold);

/// The frame's verdict on its prediction.
struct PredictionVerdict {
  /// The pose's process noise since the last update is to be taken this many times.
  double factor = 1.0;
  /// The frame was judged jointly: joint_d2 holds each observation's gate distance (in input
  /// order) after the shared pose change is fitted out, to be gated in place of its own.
  bool joint = false;
  std::vector<double> joint_d2;
};

/// Judges the prediction. Nothing (factor 1, not joint) when half of the observations or fewer
/// are gated, too few to say, or no process noise. Otherwise the factor is the one of 1 and
/// options.factors whose capped likelihood explains the innovations best (sum over the
/// observations of min(d2, likelihood_cap) + log det S, S widened by the factor; 1 when no
/// widening does: the observations disagree among themselves, not with the prediction), and the
/// frame is gated jointly. Each residual is modelled as r_i = B_i e + n_i: e the error of the
/// process noise, shared, prior N(0, factor Q); n_i independent, of covariance
/// N_i = S_i - B_i Q B_i^T. e is fitted to the observations consistent with one e (within
/// likelihood_cap once e is fitted with the widest factor), and each observation's gate distance
/// is that of r_i - B_i e against N_i plus e's covariance. The observations that disagree among
/// themselves stay beyond their gates.
PredictionVerdict judgePrediction(const std::vector<PredictionCheckInput>& observations,
                                  const Matrix6d& process_noise,
                                  const PredictionCheckOptions& options);

}  // namespace ekf_vislam
