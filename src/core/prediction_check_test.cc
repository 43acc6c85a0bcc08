#include "ekf_vislam/core/prediction_check.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace ekf_vislam {
namespace {

// Observations of landmarks ahead of a camera: each residual is B e plus pixel noise, e a pose
// error the prediction shares, B the residual's sensitivity to it; the filter believed the pose
// to within Q (process noise) and each pixel to within 2 px.
std::vector<PredictionCheckInput> observationsOf(const Eigen::Matrix<double, 6, 1>& pose_error,
                                                 const Matrix6d& Q, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> spread(-1.0, 1.0);
  std::vector<PredictionCheckInput> out;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d p(5.0 * spread(rng), 2.0 * spread(rng), 10.0 + 20.0 * (spread(rng) + 1));
    // Image rows u, v, u_right of a unit-focal camera x500 px: d/d translation and rotation.
    Eigen::Matrix<double, 3, 6> B = Eigen::Matrix<double, 3, 6>::Zero();
    const double f = 500.0, z = p.z();
    B << -f / z, 0, f * p.x() / (z * z), 0, -f, 0,  //
        0, -f / z, f * p.y() / (z * z), f, 0, 0,    //
        -f / z, 0, f * (p.x() - 0.5) / (z * z), 0, -f, 0;
    PredictionCheckInput o;
    o.noise_sensitivity = B;
    o.innovation_cov = B * Q * B.transpose() + 4.0 * Eigen::Matrix3d::Identity();
    o.residual = B * pose_error + 2.0 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    out.push_back(o);
  }
  return out;
}

Matrix6d processNoise(double translation_sigma, double rotation_sigma) {
  Matrix6d Q = Matrix6d::Zero();
  Q.diagonal() << Eigen::Vector3d::Constant(translation_sigma * translation_sigma),
      Eigen::Vector3d::Constant(rotation_sigma * rotation_sigma);
  return Q;
}

PredictionCheckOptions optionsFor3Rows() {
  PredictionCheckOptions options;
  options.gate_threshold = 7.8147;   // chi-square 95 %, 3 dof
  options.likelihood_cap = 21.1075;  // chi-square 99.99 %
  return options;
}

TEST(PredictionCheck, AGoodPredictionIsLeftAlone) {
  const Matrix6d Q = processNoise(0.05, 0.005);
  Eigen::Matrix<double, 6, 1> error;
  error << 0.03, -0.02, 0.01, 0.002, -0.004, 0.003;  // within Q
  const auto observations = observationsOf(error, Q, 60, 1);
  EXPECT_LE(gatedWithWidenedNoise(observations, Q, 1.0, 7.8147), 10);
  EXPECT_EQ(judgePrediction(observations, Q, optionsFor3Rows()).factor, 1.0);
}

int beyondGate(const std::vector<double>& d2, double gate_threshold) {
  return static_cast<int>(
      std::count_if(d2.begin(), d2.end(), [&](double v) { return !(v <= gate_threshold); }));
}

TEST(PredictionCheck, AYawTheTwistGotWrongWidensItsNoiseAndIsGatedJointly) {
  // The first frames of a run whose gyro is twice as noisy as the guessed density, one sample
  // 2.2 sigma off: 1.27 degrees of yaw against a believed 0.27.
  const Matrix6d Q = processNoise(0.03, 0.0047);
  Eigen::Matrix<double, 6, 1> error = Eigen::Matrix<double, 6, 1>::Zero();
  error(4) = 0.0222;
  const auto observations = observationsOf(error, Q, 60, 2);
  EXPECT_GT(gatedWithWidenedNoise(observations, Q, 1.0, 7.8147), 30);
  const PredictionVerdict verdict = judgePrediction(observations, Q, optionsFor3Rows());
  ASSERT_TRUE(verdict.joint);
  // The error (4.7 sigma) takes a factor near its square: 16 or 64.
  EXPECT_GE(verdict.factor, 16.0);
  EXPECT_LE(verdict.factor, 64.0);
  EXPECT_LE(gatedWithWidenedNoise(observations, Q, verdict.factor, 7.8147), 6);
  // Gated on what the fitted yaw leaves: about the 5 % a 95 % gate refuses.
  ASSERT_EQ(verdict.joint_d2.size(), observations.size());
  EXPECT_LE(beyondGate(verdict.joint_d2, 7.8147), 6);
}

TEST(PredictionCheck, AnErrorNoWideningExplainsIsStillFittedOut) {
  // 12 sigmas of yaw with the widening factors limited to 4: every landmark stays beyond its
  // capped share of the likelihood whatever the factor, so no widening is chosen, but one pose
  // change explains them all, and the joint gate passes them.
  const Matrix6d Q = processNoise(0.03, 0.0047);
  Eigen::Matrix<double, 6, 1> error = Eigen::Matrix<double, 6, 1>::Zero();
  error(4) = 12.0 * 0.0047;
  const auto observations = observationsOf(error, Q, 60, 7);
  PredictionCheckOptions options = optionsFor3Rows();
  options.factors = {4.0};
  ASSERT_GT(gatedWithWidenedNoise(observations, Q, 4.0, 7.8147), 50);
  const PredictionVerdict verdict = judgePrediction(observations, Q, options);
  ASSERT_TRUE(verdict.joint);
  EXPECT_EQ(verdict.factor, 1.0);
  EXPECT_LE(beyondGate(verdict.joint_d2, 7.8147), 6);
}

TEST(PredictionCheck, ObservationsThatDisagreeAmongThemselvesAreNotBlamedOnThePrediction) {
  // Half the landmarks 20 px off in random directions (outliers, a bad match): no pose error
  // explains them, and no widening of the pose's noise does either.
  const Matrix6d Q = processNoise(0.05, 0.005);
  auto observations = observationsOf(Eigen::Matrix<double, 6, 1>::Zero(), Q, 40, 3);
  std::mt19937 rng(4);
  std::normal_distribution<double> unit(0.0, 20.0);
  for (size_t i = 0; i < observations.size(); i += 2) {
    observations[i].residual.head<3>() += Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
  }
  for (size_t i = 1; i < observations.size(); i += 4) {
    observations[i].residual.head<3>() += Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
  }
  ASSERT_GT(gatedWithWidenedNoise(observations, Q, 1.0, 7.8147), 20);
  const PredictionVerdict verdict = judgePrediction(observations, Q, optionsFor3Rows());
  EXPECT_EQ(verdict.factor, 1.0);
  // Gated jointly, the outliers stay beyond the gate and the others pass.
  ASSERT_EQ(verdict.joint_d2.size(), observations.size());
  int outliers_gated = 0, others_gated = 0;
  for (size_t i = 0; i < observations.size(); ++i) {
    const bool outlier = i % 2 == 0 || i % 4 == 1;
    const bool gated = !(verdict.joint_d2[i] <= 7.8147);
    (outlier ? outliers_gated : others_gated) += gated ? 1 : 0;
  }
  EXPECT_GE(outliers_gated, 28);  // of 30
  EXPECT_LE(others_gated, 2);     // of 10
}

TEST(PredictionCheck, TooFewObservationsOrNoProcessNoiseSayNothing) {
  const Matrix6d Q = processNoise(0.03, 0.0047);
  Eigen::Matrix<double, 6, 1> error = Eigen::Matrix<double, 6, 1>::Zero();
  error(4) = 0.05;
  EXPECT_EQ(judgePrediction(observationsOf(error, Q, 7, 5), Q, optionsFor3Rows()).factor, 1.0);
  EXPECT_EQ(
      judgePrediction(observationsOf(error, Q, 20, 5), Matrix6d::Zero(), optionsFor3Rows()).factor,
      1.0);
  // The same 20 with their process noise: widened.
  EXPECT_GT(judgePrediction(observationsOf(error, Q, 20, 5), Q, optionsFor3Rows()).factor, 1.0);
}

}  // namespace
}  // namespace ekf_vislam
