#include "ekf_vislam/core/propagator.h"

#include "ekf_vislam/core/se3.h"
#include "testing/random_matrices.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

using testing::randomMatrix;

constexpr double kDt = 0.1;

// No process noise, no random walk: the covariance moves only through F.
VislamOptions noiselessOptions(EstimatorMode mode) {
  VislamOptions options;
  options.mode = mode;
  options.noise.linear_velocity_noise = 0.0;
  options.noise.angular_velocity_noise = 0.0;
  options.bias.velocity_random_walk = 0.0;
  options.bias.gyro_random_walk = 0.0;
  options.extrinsic.twist_rotation_random_walk = 0.0;
  options.intrinsic.disparity_offset_random_walk = 0.0;
  options.intrinsic.baseline_scale_random_walk = 0.0;
  options.bias.speed_scale_random_walk = 0.0;
  return options;
}

// Biases of v_y, w_x, w_z, speed scale, twist rotation, disparity offset, clone, two landmarks
// (27 rows), random means and covariance.
FilterState randomState(std::mt19937* rng) {
  StateLayout layout;
  layout.bias_components = {1, 3, 5};
  layout.speed_scale_dim = 1;
  layout.rotation_dim = 3;
  layout.disparity_dim = 1;
  layout.clone_dim = 6;
  FilterState state(layout);
  state.reset(StatePrior());
  for (int k = 0; k < 2; ++k) {
    state.appendLandmark(20.0 * randomMatrix(3, 1, rng), Eigen::MatrixXd::Zero(3, state.dim()),
                         Eigen::Matrix3d::Identity());
  }
  const Eigen::MatrixXd A = randomMatrix(state.dim(), state.dim(), rng);
  state.covariance() = 0.01 * A * A.transpose();
  state.imu_T_world = se3::exp(Vector6d(3.0 * randomMatrix(6, 1, rng)));
  state.imu_T_world_clone = se3::exp(Vector6d(randomMatrix(6, 1, rng)));
  state.bias = 0.1 * randomMatrix(3, 1, rng);
  state.speed_scale_error = 0.05 * randomMatrix(1, 1, rng)(0);
  state.imu_R_twist = se3::expSO3(0.05 * randomMatrix(3, 1, rng));
  return state;
}

TwistData drivingTwist() {
  TwistData twist;
  twist.v_imu = Eigen::Vector3d(8.0, 0.4, -0.2);
  twist.w_imu = Eigen::Vector3d(0.05, -0.03, 0.3);
  return twist;
}

// The mean `mean` perturbed by the error e (filter_state.h): world_T_imu = exp(eps^) world_T_imu,
// b + db, k + dk, R_m = exp(theta^) R_m, additive calibration, the clone like the pose, landmarks
// p = exp(phi^) p + xi (invariant) or p + xi.
FilterState perturbed(const FilterState& mean, const Eigen::VectorXd& e, bool invariant) {
  const StateLayout& L = mean.layout();
  FilterState x = mean;
  x.imu_T_world = se3::inverse(se3::exp(Vector6d(e.head<6>())) * se3::inverse(mean.imu_T_world));
  x.bias += e.segment(L.biasRow(), L.biasDim());
  x.speed_scale_error += e(L.speedScaleRow());
  x.imu_R_twist = se3::expSO3(e.segment<3>(L.rotationRow())) * mean.imu_R_twist;
  x.disparity_offset += e(L.disparityRow());
  x.imu_T_world_clone = se3::inverse(se3::exp(Vector6d(e.segment<6>(L.cloneRow()))) *
                                     se3::inverse(mean.imu_T_world_clone));
  const Eigen::Vector3d phi =
      invariant ? Eigen::Vector3d(e.segment<3>(3)) : Eigen::Vector3d::Zero();
  for (size_t k = 0; k < mean.landmarkCount(); ++k) {
    x.setLandmark(k, se3::expSO3(phi) * mean.landmark(k) + e.segment<3>(L.landmarkRow(k)));
  }
  return x;
}

// The error e with perturbed(mean, e) == x.
Eigen::VectorXd errorOf(const FilterState& x, const FilterState& mean, bool invariant) {
  const StateLayout& L = mean.layout();
  Eigen::VectorXd e(mean.dim());
  e.head<6>() = se3::log(se3::inverse(x.imu_T_world) * mean.imu_T_world);
  e.segment(L.biasRow(), L.biasDim()) = x.bias - mean.bias;
  e(L.speedScaleRow()) = x.speed_scale_error - mean.speed_scale_error;
  e.segment<3>(L.rotationRow()) = se3::logSO3(x.imu_R_twist * mean.imu_R_twist.transpose());
  e(L.disparityRow()) = x.disparity_offset - mean.disparity_offset;
  e.segment<6>(L.cloneRow()) = se3::log(se3::inverse(x.imu_T_world_clone) * mean.imu_T_world_clone);
  const Eigen::Vector3d phi =
      invariant ? Eigen::Vector3d(e.segment<3>(3)) : Eigen::Vector3d::Zero();
  for (size_t k = 0; k < mean.landmarkCount(); ++k) {
    e.segment<3>(L.landmarkRow(k)) = x.landmark(k) - se3::expSO3(phi) * mean.landmark(k);
  }
  return e;
}

// F = d(predicted error) / d(error) by central differences of the mean prediction.
Eigen::MatrixXd numericalTransition(const Propagator& propagator, const FilterState& mean,
                                    const TwistData& twist, bool invariant) {
  FilterState predicted = mean;
  propagator.predict(kDt, twist, 1.0, &predicted);
  const int n = mean.dim();
  const double h = 1e-6;
  Eigen::MatrixXd F(n, n);
  for (int j = 0; j < n; ++j) {
    const Eigen::VectorXd e = h * Eigen::VectorXd::Unit(n, j);
    FilterState plus = perturbed(mean, e, invariant);
    FilterState minus = perturbed(mean, -e, invariant);
    propagator.predict(kDt, twist, 1.0, &plus);
    propagator.predict(kDt, twist, 1.0, &minus);
    F.col(j) =
        (errorOf(plus, predicted, invariant) - errorOf(minus, predicted, invariant)) / (2 * h);
  }
  return F;
}

void expectCovarianceIsFPFt(const VislamOptions& options, bool invariant) {
  std::mt19937 rng(1);
  Propagator propagator(options);
  // Two earlier twists: the speed scale's reference (velocity_reference.h) is then not the
  // twist's own velocity.
  propagator.setSamplePeriod(kDt);
  for (const double vx : {6.0, 7.0}) {
    TwistData earlier = drivingTwist();
    earlier.v_imu.x() = vx;
    propagator.observeTwist(earlier);
  }
  FilterState state = randomState(&rng);
  const Eigen::MatrixXd F = numericalTransition(propagator, state, drivingTwist(), invariant);
  const Eigen::MatrixXd P = state.covariance();
  FilterState noise_only = state;
  noise_only.covariance().setZero();
  propagator.predict(kDt, drivingTwist(), 1.0, &noise_only);
  propagator.predict(kDt, drivingTwist(), 1.0, &state);

  const Eigen::MatrixXd expected = F * P * F.transpose() + noise_only.covariance();
  EXPECT_LT((state.covariance() - expected).norm(), 1e-7 * expected.norm());
  // The prediction couples the states (else the test would prove nothing).
  EXPECT_GT((F - Eigen::MatrixXd::Identity(P.rows(), P.cols())).norm(), 0.1);
}

TEST(Propagator, CovarianceIsFPFtWithInvariantLandmarksInSlamMode) {
  const VislamOptions options = noiselessOptions(EstimatorMode::kSlam);
  expectCovarianceIsFPFt(options, true);
}

TEST(Propagator, CovarianceIsFPFtWithAdditiveLandmarksInMappingMode) {
  const VislamOptions options = noiselessOptions(EstimatorMode::kMapping);
  expectCovarianceIsFPFt(options, false);
}

TEST(Propagator, CovarianceIsFPFtPlusNoiseWithTheVehiclePrior) {
  VislamOptions options = noiselessOptions(EstimatorMode::kSlam);
  options.noise.use_message_covariance = false;
  options.noise.linear_velocity_noise = 0.2;  // the vehicle prior gains differ from 1
  options.noise.angular_velocity_noise = 0.01;
  options.vehicle.lateral_velocity_sigma = 0.1;
  options.vehicle.vertical_velocity_sigma = 0.05;
  expectCovarianceIsFPFt(options, true);
}

TEST(Propagator, ProcessNoiseEntersInWorldAxesAndMovesInvariantLandmarks) {
  VislamOptions options = noiselessOptions(EstimatorMode::kSlam);
  options.noise.linear_velocity_noise = 0.2;
  options.noise.angular_velocity_noise = 0.01;
  options.bias.gyro_random_walk = 0.03;
  options.extrinsic.twist_rotation_random_walk = 0.02;
  options.intrinsic.disparity_offset_random_walk = 0.5;
  options.intrinsic.estimate_disparity_offset = true;  // a counted offset takes none either
  options.bias.estimate_speed_scale = true;            // a counted scale takes no random walk
  options.bias.speed_scale_random_walk = 0.004;
  const Propagator propagator(options);
  std::mt19937 rng(2);
  FilterState state = randomState(&rng);
  state.covariance().setZero();
  const double noise_scale = 3.0;
  propagator.predict(kDt, drivingTwist(), noise_scale, &state);

  // D maps the pose error change into the state: identity on the pose, [0, p^] per landmark.
  const StateLayout& L = state.layout();
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(state.dim(), 6);
  D.topRows<6>().setIdentity();
  for (size_t k = 0; k < 2; ++k) D.block<3, 3>(L.landmarkRow(k), 3) = se3::hat(state.landmark(k));
  const Matrix6d Ad = se3::adjoint(se3::inverse(state.imu_T_world));
  const Matrix6d Q = propagator.noiseDensity(state, drivingTwist());
  Eigen::MatrixXd expected = D * (noise_scale * kDt * Ad * Q * Ad.transpose()) * D.transpose();
  for (int i = 0; i < 3; ++i) {
    expected(L.biasRow() + i, L.biasRow() + i) += kDt * (i == 0 ? 0.0 : 0.03 * 0.03);
    expected(L.rotationRow() + i, L.rotationRow() + i) += kDt * 0.02 * 0.02;
  }
  expected(L.disparityRow(), L.disparityRow()) += kDt * 0.25;
  expected(L.speedScaleRow(), L.speedScaleRow()) += kDt * 0.004 * 0.004;
  EXPECT_LT((state.covariance() - expected).norm(), 1e-12 * expected.norm());
}

TEST(Propagator, CorrectedTwistRemovesTheBiasScalesRotatesAndAppliesTheVehiclePrior) {
  VislamOptions options;
  options.noise.use_message_covariance = false;
  options.noise.linear_velocity_noise = 0.2;      // r = 0.2^2 / 0.1 = 0.4 per sample
  options.vehicle.lateral_velocity_sigma = 0.5;   // g_y = 0.25 / (0.25 + 0.4) = 5/13
  options.vehicle.vertical_velocity_sigma = 0.0;  // no prior: g_z = 1
  Propagator propagator(options);
  propagator.setSamplePeriod(0.1);
  StateLayout layout;
  layout.bias_components = {0, 4};
  layout.speed_scale_dim = 1;
  layout.rotation_dim = 3;
  FilterState state(layout);
  state.reset(StatePrior());
  state.bias << 0.5, 0.01;
  state.speed_scale_error = 0.02;
  state.imu_R_twist = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  TwistData twist;
  // Minus bias (9.5, 1, 0.2), times 1.02, Rz: 1.02 (-1, 9.5, 0.2).
  twist.v_imu = Eigen::Vector3d(10.0, 1.0, 0.2);
  twist.w_imu =
      Eigen::Vector3d(0.1, 0.03, 0.3);  // minus bias (0.1, 0.02, 0.3), Rz: (-0.02, 0.1, 0.3)

  Vector6d expected;
  expected << -1.02, 1.02 * 9.5 * 5.0 / 13.0, 1.02 * 0.2, -0.02, 0.1, 0.3;
  EXPECT_LT((propagator.correctedTwist(state, twist) - expected).norm(), 1e-12);
}

TEST(Propagator, NoiseDensityUsesTheMessageCovarianceOnlyWhenEnabledAndNonZero) {
  VislamOptions options;
  options.noise.use_message_covariance = true;
  options.noise.linear_velocity_noise = 0.2;
  options.noise.angular_velocity_noise = 0.01;
  options.vehicle.lateral_velocity_sigma = 0.0;  // no vehicle prior: gains 1
  options.vehicle.vertical_velocity_sigma = 0.0;
  Propagator propagator(options);
  propagator.setSamplePeriod(0.05);
  StateLayout layout;
  layout.rotation_dim = 3;
  FilterState state(layout);
  state.reset(StatePrior());
  state.imu_R_twist = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Vector6d configured;
  configured << 0.04, 0.04, 0.04, 1e-4, 1e-4, 1e-4;
  TwistData twist;
  EXPECT_LT((propagator.noiseDensity(state, twist) - Matrix6d(configured.asDiagonal())).norm(),
            1e-15);

  Vector6d per_sample;
  per_sample << 0.01, 0.04, 0.09, 1e-4, 4e-4, 9e-4;
  twist.covariance = per_sample.asDiagonal();
  // Rz(90 deg) swaps the x and y variances; density = per-sample covariance x period.
  Vector6d message;
  message << 0.04, 0.01, 0.09, 4e-4, 1e-4, 9e-4;
  message *= 0.05;
  EXPECT_LT((propagator.noiseDensity(state, twist) - Matrix6d(message.asDiagonal())).norm(), 1e-15);

  options.vehicle.lateral_velocity_sigma = 0.1;  // s^2 = 0.01 against r = 0.01: g_y = 0.5
  message(1) *= 0.5;
  EXPECT_LT((propagator.noiseDensity(state, twist) - Matrix6d(message.asDiagonal())).norm(), 1e-15);

  options.noise.use_message_covariance = false;
  options.vehicle.lateral_velocity_sigma = 0.0;
  EXPECT_LT((propagator.noiseDensity(state, twist) - Matrix6d(configured.asDiagonal())).norm(),
            1e-15);
}

TEST(Propagator, OnlineTwistNoiseReplacesTheConfiguredDensitiesOnceReadyAndTheSpeedIsAveraged) {
  VislamOptions options;
  options.vehicle.lateral_velocity_sigma = options.vehicle.vertical_velocity_sigma = 0.0;
  options.noise.twist_noise_min_samples = 20;
  Propagator propagator(options);
  propagator.setSamplePeriod(0.1);
  EXPECT_DOUBLE_EQ(propagator.linearNoiseDensity(), options.noise.linear_velocity_noise);
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int k = 0; k < 400; ++k) {
    TwistData twist;
    twist.stamp = 0.1 * k;
    twist.v_imu = Eigen::Vector3d(8.0, 0.0, 0.0) +
                  0.3 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    twist.w_imu = 0.02 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    propagator.observeTwist(twist);
  }
  // Per-sample std 0.3 m/s and 0.02 rad/s at 10 Hz: densities 0.3 sqrt(0.1), 0.02 sqrt(0.1).
  EXPECT_NEAR(propagator.linearNoiseDensity(), 0.3 * std::sqrt(0.1), 0.1 * 0.3 * std::sqrt(0.1));
  EXPECT_NEAR(propagator.angularNoiseDensity(), 0.02 * std::sqrt(0.1), 0.1 * 0.02 * std::sqrt(0.1));
  // The mean forward speed of the same samples (8 m/s, noise 0.3 m/s).
  EXPECT_EQ(propagator.speedSamples(), 400u);
  EXPECT_NEAR(propagator.meanSpeed(), 8.0, 0.05);
  propagator.resetTwistEstimates();
  EXPECT_EQ(propagator.speedSamples(), 0u);
  EXPECT_EQ(propagator.meanSpeed(), 0.0);
  FilterState state(StateLayout{});
  state.reset(StatePrior());
  const Matrix6d density = propagator.noiseDensity(state, TwistData());
  EXPECT_NEAR(density(0, 0), propagator.linearNoiseDensity() * propagator.linearNoiseDensity(),
              1e-15);
  options.noise.estimate_twist_noise = false;
  EXPECT_DOUBLE_EQ(propagator.linearNoiseDensity(), options.noise.linear_velocity_noise);
}

TEST(Propagator, BeforeTheEstimateIsReadyOnlySamplesThatRejectTheGuessWidenIt) {
  VislamOptions options;
  options.noise.twist_noise_min_samples = 5;
  const double configured_w = options.noise.angular_velocity_noise;
  const double configured_v = options.noise.linear_velocity_noise;
  const double guess_w = configured_w / std::sqrt(0.1);  // per-sample std at 10 Hz
  const double guess_v = configured_v / std::sqrt(0.1);
  struct Case {
    double sigma_v, sigma_w;
    bool estimate;
  };
  // Angular noise 4 times the guess, linear a tenth of it; then both at the guess.
  for (const Case& c : {Case{0.1 * guess_v, 4.0 * guess_w, true},
                        Case{0.1 * guess_v, 4.0 * guess_w, false}, Case{guess_v, guess_w, true}}) {
    options.noise.estimate_twist_noise = c.estimate;
    Propagator propagator(options);
    propagator.setSamplePeriod(0.1);
    std::mt19937 rng(5);
    std::normal_distribution<double> normal(0.0, 1.0);
    const auto add = [&](int k) {
      TwistData twist;
      twist.stamp = 0.1 * k;
      twist.v_imu = Eigen::Vector3d(8.0, 0.0, 0.0) +
                    c.sigma_v * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      twist.w_imu = c.sigma_w * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      propagator.observeTwist(twist);
    };
    // Three samples: one second difference per component, the estimate not ready.
    for (int k = 0; k < 3; ++k) add(k);
    const bool noisier = c.estimate && c.sigma_w > guess_w;
    if (noisier) {
      EXPECT_GT(propagator.angularNoiseDensity(), 2.0 * configured_w);
    } else {
      EXPECT_DOUBLE_EQ(propagator.angularNoiseDensity(), configured_w);
    }
    EXPECT_DOUBLE_EQ(propagator.linearNoiseDensity(), configured_v);
    for (int k = 3; k < 6; ++k) add(k);
    if (!noisier) {
      EXPECT_DOUBLE_EQ(propagator.angularNoiseDensity(), configured_w);
      EXPECT_DOUBLE_EQ(propagator.linearNoiseDensity(), configured_v);
    }
    add(6);  // five second differences: the estimate itself, either way
    if (c.estimate) {
      EXPECT_NEAR(propagator.angularNoiseDensity(), c.sigma_w * std::sqrt(0.1),
                  0.6 * c.sigma_w * std::sqrt(0.1));
      EXPECT_NEAR(propagator.linearNoiseDensity(), c.sigma_v * std::sqrt(0.1),
                  0.6 * c.sigma_v * std::sqrt(0.1));
    }
  }
}

TEST(Propagator, RoadTiltIsAGaussMarkovProcessOverTheDistanceTravelled) {
  // s' = f s + w, f = exp(-d / L), Var(w) = (1 - f^2) sigma^2 over the distance d = |v| dt: rows
  // and columns of the tilt scale by f, its block gains the process noise; standing still
  // changes nothing.
  VislamOptions options = noiselessOptions(EstimatorMode::kSlam);
  options.vehicle.tilt_sigma = 0.05;
  options.vehicle.tilt_correlation_distance = 200.0;
  const Propagator propagator(options);
  StateLayout layout;  // pose and tilt: nothing else moves the cross-covariance
  layout.tilt_dim = 2;
  FilterState state(layout);
  state.reset(StatePrior());
  std::mt19937 rng(7);
  const Eigen::MatrixXd A = randomMatrix(state.dim(), state.dim(), &rng);
  state.covariance() = 1e-3 * A * A.transpose();
  state.road_tilt_world = Eigen::Vector2d(0.04, -0.02);
  const int row = layout.tiltRow();

  FilterState still = state;
  TwistData stop;
  propagator.predict(kDt, stop, 1.0, &still);
  EXPECT_LT((still.road_tilt_world - state.road_tilt_world).norm(), 1e-15);
  EXPECT_LT(
      (still.covariance().block<2, 2>(row, row) - state.covariance().block<2, 2>(row, row)).norm(),
      1e-15);

  TwistData twist;
  twist.v_imu = Eigen::Vector3d(30.0, 0.0, 0.0);  // 3 m in kDt, no turn
  FilterState moved = state;
  propagator.predict(kDt, twist, 1.0, &moved);
  const double f = std::exp(-3.0 / 200.0);
  EXPECT_LT((moved.road_tilt_world - f * state.road_tilt_world).norm(), 1e-12);
  const Eigen::Matrix2d expected_block = f * f * state.covariance().block<2, 2>(row, row) +
                                         (1.0 - f * f) * 0.05 * 0.05 * Eigen::Matrix2d::Identity();
  EXPECT_LT((moved.covariance().block<2, 2>(row, row) - expected_block).norm(), 1e-12);
  // The pose's cross-covariance with the tilt scales by f.
  EXPECT_LT(
      (moved.covariance().block<6, 2>(0, row) - f * state.covariance().block<6, 2>(0, row)).norm(),
      1e-12);

  // Far along, the tilt forgets its start: stationary std tilt_sigma, mean 0.
  for (int k = 0; k < 1000; ++k) propagator.predict(kDt, twist, 1.0, &moved);
  EXPECT_NEAR(moved.covariance()(row, row), 0.05 * 0.05, 1e-8);
  EXPECT_LT(moved.road_tilt_world.norm(), 1e-7);
}

}  // namespace
}  // namespace ekf_vislam
