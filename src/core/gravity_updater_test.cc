#include "ekf_vislam/core/gravity_updater.h"

#include "ekf_vislam/core/se3.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace ekf_vislam {
namespace {

constexpr double kG = 9.80665;

/// A drive sampled at `rate` Hz: twist k (stamp t_k) drives (t_k-1, t_k]; the accelerometer
/// sample at t_k is the mean specific force over that period in the IMU frame at t_k, at the
/// point `lever_arm` of the IMU frame (it moves at v + w^ lever_arm).
struct Drive {
  std::vector<double> t;
  std::vector<Vector6d> u;  ///< [v; w], IMU frame
  std::vector<Eigen::Matrix3d> world_R_imu;
  std::vector<Eigen::Vector3d> f;
};

Drive makeDrive(int samples, double rate, const Eigen::Vector3d& up_world,
                const Eigen::Vector3d& accel_bias, const Eigen::Matrix3d& R0,
                const Eigen::Vector3d& lever_arm = Eigen::Vector3d::Zero()) {
  Drive d;
  const double dt = 1.0 / rate;
  Eigen::Matrix3d R = R0;
  Eigen::Vector3d v_previous(8.0, 0.0, 0.0);
  for (int k = 0; k < samples; ++k) {
    const double t = 100.0 + k * dt;
    Vector6d u;
    u << 8.0 + 2.0 * std::sin(0.7 * t), 0.1 * std::cos(t), 0.02, 0.03 * std::sin(0.5 * t), -0.02,
        0.25 * std::cos(0.3 * t);
    const Eigen::Matrix3d R_previous = R;
    R = R * se3::expSO3(u.tail<3>() * dt);
    const Eigen::Vector3d v_accel = u.head<3>() + u.tail<3>().cross(lever_arm);
    const Eigen::Vector3d a_world = (R * v_accel - R_previous * v_previous) / dt;
    d.t.push_back(t);
    d.u.push_back(u);
    d.world_R_imu.push_back(R);
    d.f.push_back(R.transpose() * (a_world + kG * up_world) + accel_bias);
    v_previous = v_accel;
  }
  return d;
}

VislamOptions gravityOptions() {
  VislamOptions options;
  options.gravity.window = 0.5;
  options.gravity.magnitude = kG;
  return options;
}

FilterState gravityState(const Eigen::Matrix3d& world_R_imu) {
  StateLayout layout;
  layout.bias_components = {3, 4, 5};
  layout.gravity_dim = 5;
  FilterState state(layout);
  StatePrior prior;
  prior.position_sigma = 1e-3;
  prior.rotation_sigma = 1e-3;
  prior.gyro_bias_sigma = 1e-3;
  prior.level_sigma = 0.2;
  prior.accel_bias_sigma = 0.1;
  state.reset(prior);
  state.imu_T_world.topLeftCorner<3, 3>() = world_R_imu.transpose();
  return state;
}

/// Feeds samples [first, last] (accelerometer first at equal stamps, as the sequencer does).
void feed(const Drive& d, int first, int last, GravityUpdater* updater, FilterState* state,
          EstimatorStats* stats, const Matrix6d& u_covariance,
          const Eigen::Vector3d& dw = {0, 0, 0},
          const Eigen::Vector3d& lever_arm = Eigen::Vector3d::Zero(), double speed_scale = 1.0) {
  for (int k = first; k <= last; ++k) {
    AccelerometerData sample;
    sample.stamp = d.t[k];
    sample.f_imu = d.f[k];
    sample.p_accel_in_imu = lever_arm;
    updater->addSample(sample, stats);
    Vector6d u = d.u[k];
    u.tail<3>() += dw;
    const Eigen::Vector3d dv_d_scale = u.head<3>();  // d (s v) / d s
    u.head<3>() *= speed_scale;
    updater->onTwist(d.t[k], u, u_covariance, Eigen::MatrixXd(3, 0), dv_d_scale, state, stats);
  }
}

TEST(GravityUpdater, JacobiansMatchFiniteDifferences) {
  const Eigen::Matrix3d R = se3::expSO3(Eigen::Vector3d(0.1, -0.2, 0.7));
  const Eigen::Vector2d level(0.03, -0.05);
  const Eigen::Vector3d bias(0.01, 0.02, -0.03);
  const GravityObservation obs = predictGravity(R, level, bias, kG);
  const double h = 1e-7;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d phi = Eigen::Vector3d::Zero();
    phi(i) = h;
    const Eigen::Vector3d plus = predictGravity(se3::expSO3(phi) * R, level, bias, kG).predicted;
    const Eigen::Vector3d minus = predictGravity(se3::expSO3(-phi) * R, level, bias, kG).predicted;
    EXPECT_LT(((plus - minus) / (2 * h) - obs.H_phi.col(i)).norm(), 1e-6) << "phi " << i;
  }
  for (int i = 0; i < 2; ++i) {
    Eigen::Vector2d d = Eigen::Vector2d::Zero();
    d(i) = h;
    const Eigen::Vector3d plus = predictGravity(R, level + d, bias, kG).predicted;
    const Eigen::Vector3d minus = predictGravity(R, level - d, bias, kG).predicted;
    EXPECT_LT(((plus - minus) / (2 * h) - obs.H_level.col(i)).norm(), 1e-6) << "level " << i;
  }
  EXPECT_NEAR(upFromLevel(level).norm(), 1.0, 1e-12);
}

TEST(GravityUpdater, WindowMeasuresGravityExactly) {
  // The twist's velocity change and the gyro's rotation account for every acceleration: the
  // window's z is g R^T up + M b to rounding, whatever the drive does, also for an accelerometer
  // away from the IMU frame's origin once its lever arm is given (and not without it).
  const Eigen::Vector3d up = Eigen::Vector3d(0.05, -0.03, 1.0).normalized();
  const Eigen::Vector3d bias(0.02, -0.04, 0.03);
  const Eigen::Vector3d lever_arm(1.2, -0.4, 0.6);
  VislamOptions options = gravityOptions();
  options.gravity.window = 0.2;
  auto windowError = [&](const Eigen::Vector3d& mounted, const Eigen::Vector3d& told) {
    const Drive d = makeDrive(50, 100.0, up, bias, Eigen::Matrix3d::Identity(), mounted);
    GravityUpdater updater(options);
    FilterState state = gravityState(Eigen::Matrix3d::Identity());
    EstimatorStats stats;
    // The first window opens a window length after the first sample and closes 0.2 s later.
    feed(d, 0, 45, &updater, &state, &stats, Matrix6d::Identity() * 1e-4, {0, 0, 0}, told);
    const GravityWindow closed = updater.lastWindow();
    const int end = static_cast<int>(std::lround((closed.end - d.t[0]) * 100.0));
    EXPECT_NEAR(closed.duration, 0.2, 0.011);
    const Eigen::Vector3d expected =
        kG * d.world_R_imu[end].transpose() * up + closed.dz_dbias * bias;
    return (closed.z - expected).norm();
  };
  EXPECT_LT(windowError(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), 1e-9);
  EXPECT_LT(windowError(lever_arm, lever_arm), 1e-9);
  // The drive's angular acceleration and turn rate at 1.4 m: a few 0.01 m/s^2 unaccounted for.
  EXPECT_GT(windowError(lever_arm, Eigen::Vector3d::Zero()), 0.01);
}

// The last window (0.2 s) of a drive whose accelerometer sits on a lever arm, its twist
// perturbed: the rates by dw, the velocities scaled by speed_scale.
GravityWindow perturbedWindow(const Eigen::Vector3d& dw, double speed_scale) {
  const Eigen::Vector3d up(0.0, 0.0, 1.0);
  const Eigen::Vector3d lever_arm(1.2, -0.4, 0.6);
  const Drive d =
      makeDrive(50, 100.0, up, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(), lever_arm);
  VislamOptions options = gravityOptions();
  options.gravity.window = 0.2;
  GravityUpdater updater(options);
  FilterState state = gravityState(Eigen::Matrix3d::Identity());
  EstimatorStats stats;
  feed(d, 0, 45, &updater, &state, &stats, Matrix6d::Identity() * 1e-4, dw, lever_arm, speed_scale);
  return updater.lastWindow();
}

TEST(GravityUpdater, RateJacobianMatchesFiniteDifferences) {
  // With a lever arm: its velocities w^ r at the window's ends move with the rate too.
  const GravityWindow base = perturbedWindow(Eigen::Vector3d::Zero(), 1.0);
  const double h = 1e-6;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d dw = Eigen::Vector3d::Zero();
    dw(i) = h;
    const Eigen::Vector3d numeric =
        (perturbedWindow(dw, 1.0).z - perturbedWindow(-dw, 1.0).z) / (2 * h);
    // First order in the window's own rotation (0.05 rad here).
    EXPECT_LT((numeric - base.dz_dw.col(i)).norm(), 0.1 * numeric.norm() + 1e-6) << i;
  }
}

TEST(GravityUpdater, SpeedScaleJacobianMatchesFiniteDifferences) {
  // The twist's velocities at the window's ends scale with the speed scale; the specific force
  // does not. z is linear in the scale, so the derivative is exact.
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  const GravityWindow base = perturbedWindow(zero, 1.0);
  const double h = 1e-4;
  const Eigen::Vector3d numeric =
      (perturbedWindow(zero, 1.0 + h).z - perturbedWindow(zero, 1.0 - h).z) / (2 * h);
  // The drive accelerates: a speed error shows as an acceleration error.
  EXPECT_GT(numeric.norm(), 0.1);
  EXPECT_LT((numeric - base.dz_dscale).norm(), 1e-6 * numeric.norm());
}

TEST(GravityUpdater, HoldsRollAndPitchAndStaysConsistent) {
  // The state starts 3 degrees off in roll and pitch; the windows bring it back within a few
  // sigma of the truth, and the bias and the level are learned as the vehicle turns.
  const Eigen::Vector3d up = Eigen::Vector3d(0.02, 0.01, 1.0).normalized();
  const Eigen::Vector3d bias(0.03, -0.02, 0.05);
  const Drive d = makeDrive(3000, 100.0, up, bias, Eigen::Matrix3d::Identity());
  VislamOptions options = gravityOptions();
  GravityUpdater updater(options);
  FilterState state = gravityState(Eigen::Matrix3d::Identity());
  state.covariance().block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * std::pow(0.1, 2);
  EstimatorStats stats;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  Drive noisy = d;
  for (auto& f : noisy.f) f += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  Eigen::Matrix3d error_world = se3::expSO3(Eigen::Vector3d(0.05, -0.05, 0.0));
  for (size_t k = 0; k < d.t.size(); ++k) {
    // The pose follows the truth (as the twist would) and keeps its error until corrected.
    state.imu_T_world.topLeftCorner<3, 3>() = (error_world * d.world_R_imu[k]).transpose();
    feed(noisy, static_cast<int>(k), static_cast<int>(k), &updater, &state, &stats,
         Matrix6d::Identity() * 1e-6);
    error_world =
        state.imu_T_world.topLeftCorner<3, 3>().transpose() * d.world_R_imu[k].transpose();
  }
  EXPECT_GT(stats.get(Counter::kGravityUpdate), 50u);
  EXPECT_EQ(stats.get(Counter::kGravityIncomplete), 0u);
  // Roll and pitch error of the last pose against the truth, in world axes.
  const Eigen::Matrix3d estimate = state.imu_T_world.topLeftCorner<3, 3>().transpose();
  const Eigen::Vector3d error = se3::logSO3(estimate * d.world_R_imu.back().transpose());
  const Eigen::Vector3d level_up = upFromLevel(state.gravity_level_world);
  // What gravity sees: the estimated up in the IMU frame against the true one.
  const double tilt_error = std::acos(std::min(
      1.0,
      (estimate.transpose() * level_up).normalized().dot(d.world_R_imu.back().transpose() * up)));
  EXPECT_LT(tilt_error, 0.003) << "world rotation error " << error.transpose();
  EXPECT_LT((state.accel_bias_imu - bias).norm(), 0.03) << state.accel_bias_imu.transpose();
}

TEST(GravityUpdater, LateSamplesAndGapsAreCounted) {
  const Eigen::Vector3d up(0.0, 0.0, 1.0);
  const Drive d = makeDrive(200, 100.0, up, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  const VislamOptions options = gravityOptions();  // the updater keeps a pointer to it
  GravityUpdater updater(options);
  FilterState state = gravityState(Eigen::Matrix3d::Identity());
  EstimatorStats stats;
  feed(d, 0, 10, &updater, &state, &stats, Matrix6d::Identity() * 1e-4);
  AccelerometerData late;
  late.stamp = d.t[5];
  late.f_imu = d.f[5];
  EXPECT_FALSE(updater.addSample(late, &stats));
  EXPECT_EQ(stats.get(Counter::kAccelLate), 1u);
  // Twists without accelerometer samples: their windows are not used.
  const uint64_t updates = stats.get(Counter::kGravityUpdate);
  for (int k = 11; k < 200; ++k) {
    updater.onTwist(d.t[k], d.u[k], Matrix6d::Identity() * 1e-4, Eigen::MatrixXd(3, 0),
                    Eigen::Vector3d::Zero(), &state, &stats);
  }
  // 1.89 s of twists without samples close at least two whole 0.5 s windows, none used.
  EXPECT_GE(stats.get(Counter::kGravityIncomplete), 2u);
  EXPECT_EQ(stats.get(Counter::kGravityUpdate), updates);
}

}  // namespace
}  // namespace ekf_vislam
