#include "ekf_vislam/core/health_monitor.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace ekf_vislam {

namespace {

/// What to check when the inputs contradict each other.
constexpr char kCheckTheInputs[] =
    ": check that the twist and the camera tf use the same axes (a twist in x forward, y left, z "
    "up against a tf to x forward, y right, z down turns every yaw rate the wrong way), the "
    "camera calibration and the time stamps";

}  // namespace

std::string disagreementHint(EstimatorMode mode, uint64_t gated, uint64_t updated) {
  const uint64_t total = gated + updated;
  if (total < kDisagreementMinObservations) return "";
  const double fraction = static_cast<double>(gated) / static_cast<double>(total);
  if (fraction <= kDisagreementFraction) return "";
  std::ostringstream text;
  text.precision(3);
  text << 100.0 * fraction << " % of the re-observed landmarks (" << gated << " of " << total
       << ") disagreed with the filter and were gated";
  if (mode == EstimatorMode::kMapping) {
    text << ": in mapping mode the poses are the twist's alone and drift, and landmarks placed "
            "from them disagree with later observations (slam mode corrects the pose). If slam "
            "mode gates as many";
  } else {
    text << ", where real data gives a few %";
  }
  text << kCheckTheInputs;
  return text.str();
}

std::string widenedPredictionHint(uint64_t widened_frames, uint64_t frames) {
  if (frames < kWidenedHintMinFrames) return "";
  const double fraction = static_cast<double>(widened_frames) / static_cast<double>(frames);
  if (fraction <= kWidenedFramesFraction) return "";
  std::ostringstream text;
  text.precision(3);
  text << "in " << 100.0 * fraction << " % of the frames (" << widened_frames << " of " << frames
       << ") most re-observed landmarks disagreed with the prediction, whose noise was widened "
          "so that the images correct it (landmarks/prediction_check), where real twists give a "
          "few %"
       << kCheckTheInputs;
  return text.str();
}

std::string sparseObservationsHint(EstimatorMode mode, uint64_t observations_updated,
                                   uint64_t frames) {
  if (mode != EstimatorMode::kSlam || frames < kSparseHintMinFrames) return "";
  const double per_frame = static_cast<double>(observations_updated) / static_cast<double>(frames);
  if (per_frame >= kSparseObservationsPerFrame) return "";
  std::ostringstream text;
  text.precision(2);
  text << std::fixed << per_frame << " observations per frame updated the filter (over " << frames
       << " frames): with fewer than " << kSparseObservationsPerFrame
       << " the reported covariance has been measured too small (position NEES up to 10.8 where "
          "3 is consistent, on KITTI tracks)";
  if (per_frame < kHarmfulObservationsPerFrame) {
    text << ", and below " << kHarmfulObservationsPerFrame
         << " per frame SLAM can be less accurate than the twist alone (dead reckoning)";
  }
  text << ". Track more features per frame if the feature source allows";
  return text.str();
}

std::string featureGeometryHint(uint64_t row_rejected, uint64_t disparity_rejected,
                                uint64_t screened) {
  if (screened < kFeatureHintMinObservations) return "";
  const double total = static_cast<double>(screened);
  std::ostringstream text;
  text.precision(3);
  if (static_cast<double>(row_rejected) > kFeatureHintFraction * total) {
    text << 100.0 * static_cast<double>(row_rejected) / total << " % of the observations ("
         << row_rejected << " of " << screened
         << ") had left and right rows further apart than limits/max_row_difference_px: are the "
            "feature source's images rectified, and are its coordinates pixels of the rectified "
            "images the calibration describes?";
  } else if (static_cast<double>(disparity_rejected) > kFeatureHintFraction * total) {
    text << 100.0 * static_cast<double>(disparity_rejected) / total << " % of the observations ("
         << disparity_rejected << " of " << screened
         << ") had a disparity u_left - u_right below landmarks/min_disparity_px, negative "
            "included: are the left and right images (or u_left and u_right) swapped?";
  }
  return text.str();
}

std::string accelerometerHint(uint64_t refused, uint64_t used) {
  if (refused == 0) return "";
  std::ostringstream text;
  text << refused << " of " << refused + used
       << " accelerometer samples refused (non-finite, or |f| outside 0.3-4 g): the gravity "
          "update needs the raw specific force in m/s^2 (about 9.8 up at rest), not an "
          "acceleration with gravity removed; set gravity/enabled false for such an IMU";
  return text.str();
}

std::string slowDriveHint(EstimatorMode mode, double mean_speed, double angular_density,
                          size_t samples, bool offset_counted) {
  if (mode != EstimatorMode::kSlam || samples < kSlowDriveMinSamples ||
      !(mean_speed < kSlowDriveSpeed) || !(angular_density > kSlowDriveAngularDensity)) {
    return "";
  }
  std::ostringstream text;
  text << std::fixed;
  text.precision(4);
  text << "the twist's angular noise (" << angular_density
       << " rad/s/sqrt(Hz)) is large for a vehicle this slow (mean forward speed ";
  text.precision(2);
  text << mean_speed << " m/s): ";
  if (offset_counted) {
    text << "on such drives the estimate errs 2.9-5.3 times more than with a gyro's angular "
            "velocity (simulated at 0.5-1.5 m/s with 0.016 rad/s/sqrt(Hz) against 0.003-0.006), "
            "and its reported covariance keeps up only through the counted disparity offset "
            "(intrinsic/disparity_offset_counted_sigma; position NEES 0.6-2.4 at 0.5-3 m/s, "
            "5.6-17.6 uncounted, where 3 is consistent). ";
  } else {
    text << "on such drives the reported covariance has been several times too small (simulated "
            "at 0.5-3 m/s with 0.016 rad/s/sqrt(Hz) and 0.1-0.5 m/s of linear noise: position "
            "NEES 5.6-17.6, where 3 is consistent; at 0.006 or less it was not; a counted "
            "disparity offset, intrinsic/disparity_offset_counted_sigma, covers it). ";
  }
  text << "Take the angular velocity from a gyro (an IMU: the twist combiner) where you can";
  return text.str();
}

std::string speedErrorHint(double shown_scale, double counted_sigma, double configured_sigma) {
  if (!(configured_sigma > 0.0) || !(counted_sigma > configured_sigma * 1.001)) return "";
  std::ostringstream text;
  text << std::fixed;
  text.precision(2);
  text << "the camera's observations read the twist's speed "
       << std::abs(1.0 / shown_scale - 1.0) * 100.0 << " % too "
       << (shown_scale < 1.0 ? "high" : "low") << " (true over measured " << std::setprecision(4)
       << shown_scale << "), more than noise/twist_speed_scale_sigma (" << std::setprecision(2)
       << configured_sigma * 100.0 << " %): the reported covariance counts "
       << counted_sigma * 100.0
       << " %, the estimate is not corrected. Calibrate the odometry's scale (a wheel radius), or "
          "let the filter estimate it (bias/estimate_speed_scale: true)";
  return text.str();
}

std::string disparityOffsetHint(double shown_px, double counted_px, double configured_px) {
  if (!(configured_px > 0.0) || !(counted_px > configured_px)) return "";
  std::ostringstream text;
  text << std::fixed;
  text.precision(2);
  text << "the camera's observations read the stereo disparities " << std::abs(shown_px)
       << " px too " << (shown_px > 0.0 ? "large" : "small")
       << " against the twist's motion, more than intrinsic/disparity_offset_counted_sigma ("
       << configured_px << " px): the reported covariance counts " << counted_px
       << " px, the estimate is not corrected. A rig whose rectification is off reads so, and so "
          "does a noisy twist's own error: check the rig (the tracker's rig check) and the "
          "odometry; on a rig known to be off, let the filter estimate the offset "
          "(intrinsic/estimate_disparity_offset: true)";
  return text.str();
}

std::string roadTiltHint(double road_tilt_deg, const VehicleOptions& vehicle) {
  const double prior_deg = vehicle.tilt_sigma * 180.0 / M_PI;
  if (!(vehicle.tilt_sigma > 0.0) || !(road_tilt_deg > kTiltHintSigmas * prior_deg)) return "";
  std::ostringstream text;
  text.precision(1);
  text << std::fixed << "the road's tilt is estimated at " << road_tilt_deg
       << " deg from the start's level, more than " << kTiltHintSigmas << " times its prior ("
       << "vehicle/tilt_sigma: " << prior_deg
       << " deg): the road is steeper than the prior allows (then raise tilt_sigma), or drifting "
          "tracks are turning the vehicle's roll and pitch; either way its height is not to be "
          "trusted";
  if (vehicle.count_shown_tilt_error) {
    text << " (without an accelerometer the reported covariance counts the excess over twice the "
            "prior as tilt error: vehicle/count_shown_tilt_error)";
  }
  return text.str();
}

std::string travelDirectionHint(const TravelDirectionEstimator& travel,
                                const VehicleOptions& vehicle) {
  if (travel.samples() < kTravelHintMinSamples) return "";
  const bool lateral =
      vehicle.lateral_velocity_sigma > 0.0 && std::abs(travel.yaw()) > kTravelHintAngle;
  const bool vertical =
      vehicle.vertical_velocity_sigma > 0.0 && std::abs(travel.pitch()) > kTravelHintAngle;
  if (!lateral && !vertical) return "";
  std::ostringstream text;
  text.precision(2);
  text << std::fixed << "the twist travels " << travel.yawDegrees() << " deg towards its y and "
       << travel.pitchDegrees()
       << " deg towards its z, not along its x axis: the vehicle prior (vehicle/*_velocity_sigma) "
          "takes that part of the velocity for noise. Give the twist in a frame whose x is the "
          "vehicle's direction of travel, or set the two sigmas to 0";
  return text.str();
}

bool HealthMonitor::diverged(int candidates, int disagreeing, double position_sigma,
                             std::string* why) {
  if (candidates >= 10 && disagreeing > options_->health.rejected_fraction * candidates) {
    ++consecutive_rejected_frames_;
  } else {
    consecutive_rejected_frames_ = 0;
  }
  std::ostringstream text;
  if (!std::isfinite(position_sigma) || position_sigma > options_->health.max_position_sigma) {
    text << "pose covariance blew up (position sigma " << position_sigma
         << " m > health/max_position_sigma)";
  } else if (consecutive_rejected_frames_ >= options_->health.max_rejected_frames) {
    text << consecutive_rejected_frames_ << " consecutive frames with most observations gated";
  } else {
    return false;
  }
  consecutive_rejected_frames_ = 0;
  *why = text.str();
  return true;
}

}  // namespace ekf_vislam
