#include "ekf_vislam/core/prediction_check.h"

#include <Eigen/Cholesky>

#include <algorithm>

namespace ekf_vislam {

namespace {

Eigen::MatrixXd widened(const PredictionCheckInput& o, const Matrix6d& process_noise,
                        double factor) {
  Eigen::MatrixXd S = o.innovation_cov;
  if (factor != 1.0) {
    S += (factor - 1.0) * o.noise_sensitivity * process_noise * o.noise_sensitivity.transpose();
  }
  return S;
}

}  // namespace

int gatedWithWidenedNoise(const std::vector<PredictionCheckInput>& observations,
                          const Matrix6d& process_noise, double factor, double gate_threshold) {
  int gated = 0;
  for (const PredictionCheckInput& o : observations) {
    const Eigen::MatrixXd S = widened(o, process_noise, factor);
    const double d2 = o.residual.dot(S.ldlt().solve(o.residual));
    if (!(d2 <= gate_threshold)) ++gated;
  }
  return gated;
}

double cappedNegativeLogLikelihood(const std::vector<PredictionCheckInput>& observations,
                                   const Matrix6d& process_noise, double factor, double cap) {
  double sum = 0.0;
  for (const PredictionCheckInput& o : observations) {
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(widened(o, process_noise, factor));
    const double d2 = o.residual.dot(ldlt.solve(o.residual));
    sum += std::min(d2, cap) + ldlt.vectorD().array().log().sum();
  }
  return sum;
}

double predictionNoiseFactor(const std::vector<PredictionCheckInput>& observations,
                             const Matrix6d& process_noise, const PredictionCheckOptions& options) {
  if (!(process_noise.trace() > 0.0) ||
      !predictionSuspected(
          gatedWithWidenedNoise(observations, process_noise, 1.0, options.gate_threshold),
          static_cast<int>(observations.size()), options)) {
    return 1.0;
  }
  double best = 1.0;
  double best_score =
      cappedNegativeLogLikelihood(observations, process_noise, 1.0, options.likelihood_cap);
  for (double factor : options.factors) {
    const double score =
        cappedNegativeLogLikelihood(observations, process_noise, factor, options.likelihood_cap);
    if (score < best_score) {
      best = factor;
      best_score = score;
    }
  }
  return best;
}

}  // namespace ekf_vislam
