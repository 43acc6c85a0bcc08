// The accelerometer's gravity update (gravity/, SLAM mode): roll and pitch held against gravity.
// Over a window [s_a, s_b] of twist samples, the accelerometer samples (each the mean specific
// force over the period ending at its stamp) rotated into the IMU frame at s_b by the gyro give
// the window's mean specific force; less the acceleration the twist shows,
//
//   z = (sum_i R_{b<-i} f_i dt_i) / dt - (v_b - R_{b<-a} v_a) / dt  =  g R_b^T up + b_a + n,
//
// R_b = world_R_imu at s_b, up = gravity's up axis in world axes (level state: its x and y), b_a
// the accelerometer bias (M b_a: M the mean rotation from a sample to s_b). An accelerometer at
// r in the IMU frame (its lever arm) moves at v + w^ r: that velocity stands for v at both ends,
// and the equation holds for it exactly. Windows do not share a twist sample, so their noises are
// independent. The noise: the accelerometer's (message
// covariance, else estimated online from its samples), the two velocities' and the gyro's over the
// window. No ROS.
#pragma once

#include "ekf_vislam/core/estimator_stats.h"
#include "ekf_vislam/core/filter_state.h"
#include "ekf_vislam/core/state_helper.h"
#include "ekf_vislam/core/twist_noise_estimator.h"
#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

namespace ekf_vislam {

/// The observation of one window at the state: h = g R^T up(level) + b_a and its Jacobians with
/// respect to the pose's rotation error phi (world axes, R = exp(phi^) R_mean), the level (2) and
/// the bias (identity).
struct GravityObservation {
  Eigen::Vector3d predicted = Eigen::Vector3d::Zero();
  Eigen::Matrix3d H_phi = Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 3, 2> H_level = Eigen::Matrix<double, 3, 2>::Zero();
};

GravityObservation predictGravity(const Eigen::Matrix3d& world_R_imu,
                                  const Eigen::Vector2d& level_world,
                                  const Eigen::Vector3d& accel_bias_imu, double magnitude);

/// Gravity's up axis in world axes from the level state (x, y; z >= 0).
Eigen::Vector3d upFromLevel(const Eigen::Vector2d& level_world);

/// One window's measurement, before the state is consulted.
struct GravityWindow {
  double end = 0.0;                                 ///< s_b
  double duration = 0.0;                            ///< s_b - s_a
  Eigen::Vector3d z = Eigen::Vector3d::Zero();      ///< m/s^2, IMU frame at s_b
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();  ///< covariance of z
  /// dz / d(gyro rate error), IMU axes (a rate error turns the rotations of the window).
  Eigen::Matrix3d dz_dw = Eigen::Matrix3d::Zero();
  /// dz / d(accelerometer bias): the mean of the rotations from each sample to s_b (the bias
  /// is constant in the IMU frame, which turns during the window).
  Eigen::Matrix3d dz_dbias = Eigen::Matrix3d::Identity();
  /// dz / d(twist speed scale): the velocities at both ends scale with it.
  Eigen::Vector3d dz_dscale = Eigen::Vector3d::Zero();
};

class GravityUpdater {
 public:
  /// Accelerometer samples kept waiting for their twist at most.
  static constexpr size_t kMaxPending = 10000;
  /// A stamp not set yet.
  static constexpr double kNoStamp = -1e300;

  explicit GravityUpdater(const VislamOptions& options);

  /// Forgets the window, the waiting samples and the noise estimate (filter reset).
  void reset();
  /// A screened sample, in stamp order; false (counted accel_late) when older than the last
  /// twist integrated or than the previous sample.
  bool addSample(const AccelerometerData& sample, EstimatorStats* stats);

  /// After the filter was predicted to twist_stamp with the corrected twist u = [v; w] (IMU
  /// frame) of covariance u_covariance (one sample) that drove (previous twist, twist_stamp]:
  /// integrates the samples up to twist_stamp and, when a window closes, updates the state.
  /// d_w_d_bias (3 x biasDim, may be empty): how the corrected rate moves with the bias state;
  /// d_v_d_scale: how the corrected velocity moves with the speed scale state (zero without
  /// it). The outcome, or nothing when no update was due.
  std::optional<UpdateStatus> onTwist(double twist_stamp, const Vector6d& u,
                                      const Matrix6d& u_covariance,
                                      const Eigen::MatrixXd& d_w_d_bias,
                                      const Eigen::Vector3d& d_v_d_scale, FilterState* state,
                                      EstimatorStats* stats);

  /// An accelerometer sample came since the reset (before, onTwist does nothing).
  bool hasSamples() const { return last_added_stamp_ != kNoStamp; }
  /// The last window closed (tests, diagnostics).
  const GravityWindow& lastWindow() const { return last_window_; }
  /// Per-sample noise std of the accelerometer in use now (m/s^2, each axis) for samples this
  /// far apart.
  double sampleSigma(double period) const;

 private:
  void integrateSamples(double twist_stamp, const Eigen::Vector3d& w);
  /// The accelerometer's velocity v + w^ r (IMU axes) and its covariance, from the twist u.
  std::pair<Eigen::Vector3d, Eigen::Matrix3d> accelVelocity(const Vector6d& u,
                                                            const Matrix6d& u_covariance) const;
  void openWindow(double stamp, const Vector6d& u, const Matrix6d& u_covariance,
                  const Eigen::Vector3d& d_v_d_scale);
  /// The open window's measurement, closed at the twist `end` of velocity v_end (the
  /// accelerometer's, covariance v_end_covariance, derivative by the speed scale d_v_d_scale).
  GravityWindow closeWindow(double end, const Eigen::Vector3d& v_end,
                            const Eigen::Matrix3d& v_end_covariance,
                            const Eigen::Vector3d& d_v_d_scale) const;
  UpdateStatus apply(const GravityWindow& window, const Eigen::MatrixXd& d_w_d_bias,
                     FilterState* state, EstimatorStats* stats);

  const VislamOptions* options_;         ///< not owned (the estimator keeps it alive)
  TwistNoiseEstimator noise_estimator_;  ///< the accelerometer's, its samples as linear parts
  /// A sample waiting for its twist, with the stamp of the sample before it (its period starts
  /// there) and its noise variance (each axis) as it was when the sample came: read then, it
  /// depends on the samples before it only, not on when the twists come (live equals offline).
  struct PendingSample {
    AccelerometerData sample;
    double previous_stamp = kNoStamp;
    double variance = 0.0;
  };
  std::deque<PendingSample> pending_;
  double last_added_stamp_ = kNoStamp;  ///< stamp of the last sample accepted
  double last_twist_stamp_ = kNoStamp;
  /// The lever arm of the last sample integrated (fixed by the mount; read in stamp order).
  Eigen::Vector3d p_accel_in_imu_ = Eigen::Vector3d::Zero();
  /// A window opens at a twist after this stamp: a window length after the first sample, then
  /// (once one opened) any.
  double windows_open_after_ = kNoStamp;

  bool open_ = false;
  double start_ = 0.0;
  Eigen::Vector3d v_start_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d v_start_covariance_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d v_start_d_scale_ = Eigen::Vector3d::Zero();  ///< d v_start / d speed scale
  Eigen::Matrix3d start_R_now_ = Eigen::Matrix3d::Identity();  ///< R_{a<-last twist}
  Eigen::Vector3d force_sum_ = Eigen::Vector3d::Zero();        ///< sum R_{a<-i} f_i dt_i
  Eigen::Vector3d force_time_sum_ = Eigen::Vector3d::Zero();  ///< sum R_{a<-i} f_i dt_i (s_i - s_a)
  double covered_ = 0.0;                                      ///< sum dt_i
  Eigen::Matrix3d rotation_sum_ = Eigen::Matrix3d::Zero();    ///< sum R_{a<-i} dt_i
  double force_variance_ = 0.0;                               ///< sum dt_i^2 sigma_i^2 (each axis)
  Eigen::Matrix3d rotation_covariance_ = Eigen::Matrix3d::Zero();  ///< gyro noise over the window
  GravityWindow last_window_;
};

}  // namespace ekf_vislam
