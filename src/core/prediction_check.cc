#include "ekf_vislam/core/prediction_check.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>

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

/// Sum over the observations of min(d2, cap) + log det S with the process noise taken `factor`
/// times: the negative log-likelihood of the innovations (up to a constant), each observation's
/// share capped so that outliers do not choose the factor.
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

/// One observation without the process noise's part: n_i's covariance N_i = S_i - B_i Q B_i^T
/// and what the fit needs of it.
struct WhitenedObservation {
  Eigen::LDLT<Eigen::MatrixXd> N;
  Eigen::MatrixXd Ninv_B;  ///< N^-1 B
  Eigen::VectorXd Ninv_r;  ///< N^-1 r
};

/// The shared error e fitted with the prior N(0, a Q): information J = sum B^T N^-1 B and
/// g = sum B^T N^-1 r over the observations used; mean P g, covariance P = a Q (I + J a Q)^-1.
struct SharedErrorFit {
  Vector6d mean = Vector6d::Zero();
  Matrix6d cov = Matrix6d::Zero();
};

SharedErrorFit fitSharedError(const std::vector<PredictionCheckInput>& observations,
                              const std::vector<WhitenedObservation>& whitened,
                              const std::vector<bool>& used, const Matrix6d& process_noise,
                              double factor) {
  Matrix6d J = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  for (size_t i = 0; i < observations.size(); ++i) {
    if (!used[i]) continue;
    J += observations[i].noise_sensitivity.transpose() * whitened[i].Ninv_B;
    g += observations[i].noise_sensitivity.transpose() * whitened[i].Ninv_r;
  }
  const Matrix6d aQ = factor * process_noise;
  const Eigen::PartialPivLU<Matrix6d> lu(Matrix6d::Identity() + J * aQ);
  SharedErrorFit fit;
  fit.cov = aQ * lu.inverse();
  fit.cov = 0.5 * (fit.cov + fit.cov.transpose()).eval();
  fit.mean = fit.cov * g;
  return fit;
}

/// d2 of r - B e against N, e the fit's mean.
double distanceAfterFit(const PredictionCheckInput& o, const WhitenedObservation& w,
                        const SharedErrorFit& fit) {
  const Eigen::VectorXd rest = o.residual - o.noise_sensitivity * fit.mean;
  return rest.dot(w.N.solve(rest));
}

/// The observations consistent with one shared error: fitted with the widest factor (the
/// least-squares pose change), those within the cap; refitted to those once.
std::vector<bool> consistentObservations(const std::vector<PredictionCheckInput>& observations,
                                         const std::vector<WhitenedObservation>& whitened,
                                         const Matrix6d& process_noise, double widest, double cap) {
  std::vector<bool> used(observations.size(), true);
  for (int pass = 0; pass < 2; ++pass) {
    const SharedErrorFit fit = fitSharedError(observations, whitened, used, process_noise, widest);
    for (size_t i = 0; i < observations.size(); ++i) {
      used[i] = distanceAfterFit(observations[i], whitened[i], fit) <= cap;
    }
  }
  return used;
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

PredictionVerdict judgePrediction(const std::vector<PredictionCheckInput>& observations,
                                  const Matrix6d& process_noise,
                                  const PredictionCheckOptions& options) {
  PredictionVerdict verdict;
  if (!(process_noise.trace() > 0.0) ||
      !predictionSuspected(
          gatedWithWidenedNoise(observations, process_noise, 1.0, options.gate_threshold),
          static_cast<int>(observations.size()), options)) {
    return verdict;
  }
  double best_score =
      cappedNegativeLogLikelihood(observations, process_noise, 1.0, options.likelihood_cap);
  for (double factor : options.factors) {
    const double score =
        cappedNegativeLogLikelihood(observations, process_noise, factor, options.likelihood_cap);
    if (score < best_score) {
      verdict.factor = factor;
      best_score = score;
    }
  }
  std::vector<WhitenedObservation> whitened;
  whitened.reserve(observations.size());
  for (const PredictionCheckInput& o : observations) {
    WhitenedObservation w;
    w.N.compute(widened(o, process_noise, 0.0));
    // Q is the process noise since the last update; the updates of the vehicle's priors may have
    // taken part of it out of S since. Where S no longer holds it, n_i keeps all of S.
    if (w.N.info() != Eigen::Success || !(w.N.vectorD().minCoeff() > 0.0)) {
      w.N.compute(o.innovation_cov);
    }
    w.Ninv_B = w.N.solve(o.noise_sensitivity);
    w.Ninv_r = w.N.solve(o.residual);
    whitened.push_back(std::move(w));
  }
  double widest = 1.0;
  for (double factor : options.factors) widest = std::max(widest, factor);
  const std::vector<bool> used =
      consistentObservations(observations, whitened, process_noise, widest, options.likelihood_cap);
  const SharedErrorFit fit =
      fitSharedError(observations, whitened, used, process_noise, verdict.factor);
  verdict.joint = true;
  verdict.joint_d2.reserve(observations.size());
  for (size_t i = 0; i < observations.size(); ++i) {
    const PredictionCheckInput& o = observations[i];
    const Eigen::VectorXd rest = o.residual - o.noise_sensitivity * fit.mean;
    const Eigen::MatrixXd cov = whitened[i].N.reconstructedMatrix() +
                                o.noise_sensitivity * fit.cov * o.noise_sensitivity.transpose();
    verdict.joint_d2.push_back(rest.dot(cov.ldlt().solve(rest)));
  }
  return verdict;
}

}  // namespace ekf_vislam
