// Divergence detection: a pose covariance that blew up, or many frames in a row in which most
// observations disagree with the filter (health/ options). No ROS.
#pragma once

#include "ekf_vislam/core/travel_direction_estimator.h"
#include "ekf_vislam/core/vislam_options.h"

#include <cmath>
#include <cstdint>
#include <string>

namespace ekf_vislam {

/// A hint when many re-observed landmarks disagree with the filter: more than
/// kDisagreementFraction of them gated (out of at least kDisagreementMinObservations), where real
/// data gives a few percent. Such disagreement usually means the inputs contradict each other (a
/// twist in other axes than the camera tf's, a wrong calibration, shifted time stamps) rather than
/// a divergence. In mapping mode the poses are the twist's alone and drift, so the landmarks
/// placed from them disagree more and more with later observations: the hint says so first.
/// Empty when the fraction is ordinary.
constexpr double kDisagreementFraction = 0.2;
constexpr uint64_t kDisagreementMinObservations = 50;
std::string disagreementHint(EstimatorMode mode, uint64_t gated, uint64_t updated);

/// A hint when the prediction check (landmarks/prediction_check) had to widen the prediction's
/// noise in more than kWidenedFramesFraction of at least kWidenedHintMinFrames frames: most
/// re-observed landmarks disagreed with the prediction frame after frame, where real twists do so
/// in a few % of the frames (3.41 % with four times the KITTI course files' angular noise). The
/// images then correct a twist that contradicts them (other axes than the camera tf's, a wrong
/// calibration, shifted stamps), so few observations are gated and disagreementHint stays silent:
/// this one says so. Empty when the fraction is ordinary.
constexpr double kWidenedFramesFraction = 0.1;
constexpr uint64_t kWidenedHintMinFrames = 100;
std::string widenedPredictionHint(uint64_t widened_frames, uint64_t frames);

/// A hint when the vehicle prior is on and the twist travels more than kTravelHintAngle off its
/// x axis (yaw for the lateral prior, pitch for the vertical one), over at least
/// kTravelHintMinSamples moving samples (30 s at 10 Hz): the prior then takes a part of the true
/// velocity proportional to the speed for noise (1 degree: 1.7 % of it). Empty otherwise.
constexpr double kTravelHintAngle = 1.0 * M_PI / 180.0;
constexpr size_t kTravelHintMinSamples = 300;
std::string travelDirectionHint(const TravelDirectionEstimator& travel,
                                const VehicleOptions& vehicle);

/// A hint when few observations update the filter: on average fewer than
/// kSparseObservationsPerFrame per feature frame, over at least kSparseHintMinFrames frames
/// (SLAM mode only: in the other modes the pose is the twist's). Measured on the
/// KITTI course tracks (doc/experiments.md, landmark study): about 10 updates per frame gave a
/// position NEES of 2.2-4.9, 5 per frame up to 7.9, 2-2.7 per frame up to 10.8 (3 is
/// consistent); below kHarmfulObservationsPerFrame SLAM was 1.3-1.8x the dead reckoning's ATE
/// with a good twist. Empty otherwise.
constexpr double kSparseObservationsPerFrame = 8.0;
constexpr double kHarmfulObservationsPerFrame = 1.0;
constexpr uint64_t kSparseHintMinFrames = 100;
std::string sparseObservationsHint(EstimatorMode mode, uint64_t observations_updated,
                                   uint64_t frames);

/// A hint when the twist's angular noise is large for how slowly the vehicle moves (SLAM mode):
/// a mean forward speed below kSlowDriveSpeed with an angular noise density (estimated, or
/// configured) above kSlowDriveAngularDensity, over at least kSlowDriveMinSamples twist
/// samples. Each frame's correction of that rotation noise then moves the many landmarks seen
/// again and again along their inverse-depth lines, which pushes them out a little each time,
/// and the reported covariance does not know it. Measured on simulated 1000-frame drives at 10
/// Hz (doc/experiments.md, 2-3 seeds each, position NEES where 3 is consistent): 0.05 rad/s per
/// sample (0.016 rad/s/sqrt(Hz), the course files' gyro noise) gave 5.68-17.62 at 0.5-1.5 m/s
/// with 0.1-0.5 m/s of linear noise (2.34-2.35 with 0.05: the counted speed error,
/// noise/twist_speed_scale_sigma, covers that one, so the hint errs on the side of caution
/// there), 5.63-7.61 at 1.5-3 m/s and 1.32-3.08 at 3-6 m/s; 0.02 rad/s per sample (0.0063
/// rad/s/sqrt(Hz)) or less gave 0.46-1.24 at 0.5-3 m/s. A counted disparity offset
/// (`offset_counted`: intrinsic/disparity_offset_counted_sigma, 0.1 px) covers that push: 0.63-2.37
/// at 0.5-3 m/s; the estimate still errs 2.88-5.33 times more than with 0.01-0.02 rad/s, and the
/// hint says which. The mean speed is the run's so far (long stops lower it). Empty otherwise.
constexpr double kSlowDriveSpeed = 3.0;            ///< m/s
constexpr double kSlowDriveAngularDensity = 0.01;  ///< rad/s/sqrt(Hz)
constexpr size_t kSlowDriveMinSamples = 300;
std::string slowDriveHint(EstimatorMode mode, double mean_speed, double angular_density,
                          size_t samples, bool offset_counted);

/// A hint when the counted speed error grew beyond the configured one
/// (noise/count_observed_speed_error): the observations show the twist's speed off by more than
/// noise/twist_speed_scale_sigma, the reported covariance counts it, the estimate is uncorrected.
/// `shown_scale` is the true speed over the measured one the observations read, `counted_sigma`
/// the sigma counted now. Empty otherwise.
std::string speedErrorHint(double shown_scale, double counted_sigma, double configured_sigma);

/// A hint when the counted disparity offset grew beyond the configured one
/// (intrinsic/count_shown_disparity_offset): the observations show the rig's disparities off by
/// more than intrinsic/disparity_offset_counted_sigma against the motion, the reported covariance
/// counts it, the estimate is uncorrected. `shown_px` is the offset read (measured minus true),
/// `counted_px` the sigma the shown offset set (VislamEstimator::disparityOffsetCountedShown).
/// Empty otherwise.
std::string disparityOffsetHint(double shown_px, double counted_px, double configured_px);

/// A hint when the road tilt state (vehicle/tilt_sigma, SLAM mode) lies more than
/// kTiltHintSigmas prior standard deviations from the start's level: either the road is steeper
/// than the prior allows, or drifting tracks are turning the vehicle's roll and pitch (the
/// KITTI-360 course file: 28.3 degrees against a 2.9-degree prior, its height 207.5 m off after
/// 1350 m); its height is then not to be trusted. Empty when the prior is off or the tilt within.
constexpr double kTiltHintSigmas = 3.0;
std::string roadTiltHint(double road_tilt_deg, const VehicleOptions& vehicle);

/// A hint when the stereo features themselves look wrong: of at least kFeatureHintMinObservations
/// screened observations, more than kFeatureHintFraction rejected because their left and right
/// rows disagree (images not rectified, or rows not the rectified images' pixels), or because
/// their disparity u_left - u_right is below landmarks/min_disparity_px (negative: left and right
/// swapped). The course files reject 0.18-2.1 % for their disparity and none for their rows
/// (doc/ros.md); empty otherwise.
constexpr double kFeatureHintFraction = 0.5;
constexpr uint64_t kFeatureHintMinObservations = 200;
std::string featureGeometryHint(uint64_t row_rejected, uint64_t disparity_rejected,
                                uint64_t screened);

/// Accelerometer samples refused (non-finite, or |f| outside 0.3-4 g: a driver that removes
/// gravity, other units): what to check. Empty when none was.
std::string accelerometerHint(uint64_t refused, uint64_t used);

class HealthMonitor {
 public:
  explicit HealthMonitor(const VislamOptions& options) : options_(&options) {}

  /// One frame: `candidates` re-observed landmarks of which `disagreeing` were gated or jumped,
  /// and the position sigma (world axes) after it. True when the filter diverged (*why says
  /// how); the count of bad frames then restarts.
  bool diverged(int candidates, int disagreeing, double position_sigma, std::string* why);
  void reset() { consecutive_rejected_frames_ = 0; }

 private:
  const VislamOptions* options_;  ///< not owned (the estimator keeps it alive)
  int consecutive_rejected_frames_ = 0;
};

}  // namespace ekf_vislam
