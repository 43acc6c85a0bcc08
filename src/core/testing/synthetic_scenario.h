// A small synthetic drive for the core's unit tests (the product's simulator is the Python
// scripts/simulate_dataset.py; this one keeps the C++ tests free of files and Python).
#pragma once

#include "ekf_vislam/core/types.h"
#include "ekf_vislam/core/vislam_options.h"

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <vector>

namespace ekf_vislam {
namespace testing {

struct ScenarioOptions {
  int frames = 300;
  double dt = 0.1;
  double pixel_sigma = 1.0;
  /// Drifting tracks: each track's pixel error is AR(1) with this correlation from one frame to
  /// the next (stationary std pixel_sigma); 0: white.
  double pixel_correlation = 0.0;
  /// Tracks that wander: each track's pixel error also takes a random step of this rate
  /// (px/sqrt(s)) every frame, the same in both images (the point it shows moves across the ray,
  /// its disparity kept); 0: none.
  double pixel_random_walk = 0.0;
  /// Tracks that turn away from their points: an observation of age a (s since its track
  /// started) shows the point turned by exp(a w^) about the IMU origin (rad/s, IMU axes).
  Eigen::Vector3d track_drift_rate_imu = Eigen::Vector3d::Zero();
  double linear_velocity_noise = 0.5;    ///< per sample, m/s
  double angular_velocity_noise = 0.05;  ///< per sample, rad/s
  Eigen::Vector3d gyro_bias = Eigen::Vector3d(0.006, -0.008, 0.007);
  double outlier_rate = 0.0;
  /// Measured disparity minus the true one, px (uR shifted by minus this; real tracks: ~+0.5).
  double disparity_offset_px = 0.0;
  int target_observations = 70;
  /// A stop: the vehicle slows to rest over 20 frames before stop_first_frame, stands still for
  /// stop_frames (0: no stop) and drives off over 20 frames. At rest the measured linear velocity
  /// is exactly 0 (a wheel odometry), the gyro keeps its noise and bias, and each track keeps its
  /// pixel error (the same view gives the same track) but for rest_pixel_jitter.
  int stop_first_frame = 0;
  int stop_frames = 0;
  double rest_pixel_jitter = 0.02;  ///< px
  uint32_t seed = 1;
  /// Accelerometer: white noise per sample (m/s^2; negative: no accelerometer), constant bias,
  /// and gravity's up axis in world axes (the world is the first pose).
  double accel_noise = -1.0;
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d up_world = Eigen::Vector3d::UnitZ();
  /// m, where the accelerometer sits in the IMU frame (each sample carries it).
  Eigen::Vector3d accel_lever_arm = Eigen::Vector3d::Zero();
};

struct Scenario {
  StereoCalibration calibration;
  std::vector<TwistData> twists;       ///< measured, one per frame
  std::vector<TwistData> true_twists;  ///< noiseless, bias-free
  std::vector<FeatureFrame> frames;    ///< one per frame, same stamps
  /// One per frame, same stamps (ScenarioOptions::accel_noise >= 0): the mean specific force over
  /// the period ending there at ScenarioOptions::accel_lever_arm, IMU axes.
  std::vector<AccelerometerData> accels;
  std::vector<Eigen::Matrix4d> world_T_imu;  ///< ground truth per frame
  std::vector<bool> still;  ///< per frame: the pose is the previous frame's (a stop)
  std::map<uint32_t, Eigen::Vector3d> p_world;  ///< ground truth landmark of each id
};

/// KITTI-like stereo rig driving a curvy road with landmarks on both sides. Twist k+1 drives
/// [t_k, t_k+1] (the estimator's convention). Deterministic from the seed.
Scenario makeScenario(const ScenarioOptions& options);

/// The shipped defaults with the noise matched to the scenario's (pixel sigma and correlation;
/// per-sample twist noise turned into densities with the frame period): a correctly specified
/// filter. Its tracks stay on their points, so landmarks are not split
/// (landmarks/max_track_length = 0).
VislamOptions matchedOptions(const ScenarioOptions& scenario);

/// KITTI-like calibration (fx 707, baseline 0.537 m, image 1241x376).
StereoCalibration kittiLikeCalibration();

}  // namespace testing
}  // namespace ekf_vislam
