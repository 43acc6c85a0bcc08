#include "ekf_vislam/core/vislam_options.h"

#include "ekf_vislam/core/option_reader.h"

namespace ekf_vislam {

namespace {

constexpr EnumNames<EstimatorMode, 3> kModeNames{{{"deadreckoning", EstimatorMode::kDeadReckoning},
                                                  {"mapping", EstimatorMode::kMapping},
                                                  {"slam", EstimatorMode::kSlam}}};
constexpr EnumNames<GapPolicy, 2> kGapPolicyNames{
    {{"predict", GapPolicy::kPredict}, {"reset", GapPolicy::kReset}}};
constexpr EnumNames<RepeatedFramePolicy, 3> kRepeatedFrameNames{
    {{"use", RepeatedFramePolicy::kUse},
     {"skip", RepeatedFramePolicy::kSkip},
     {"shift", RepeatedFramePolicy::kShift}}};
constexpr EnumNames<DivergencePolicy, 2> kDivergenceNames{
    {{"reset_landmarks", DivergencePolicy::kResetLandmarks},
     {"reset_filter", DivergencePolicy::kResetFilter}}};

/// The key table: every key once, with its field and range (config/default.yaml documents
/// them in the same order). `Options` is VislamOptions or const VislamOptions.
template <typename Options, typename Visitor>
void visitVislamOptions(Options& o, Visitor& v) {
  v.choice("mode", o.mode, kModeNames);

  auto& noise = o.noise;
  v.number("noise/pixel_sigma", noise.pixel_sigma, Bound::kPositive);
  v.number("noise/pixel_correlation", noise.pixel_correlation, Bound::kCorrelation);
  v.flag("noise/merge_stereo_rows", noise.merge_stereo_rows);
  v.number("noise/track_random_walk", noise.track_random_walk, Bound::kNonNegative);
  v.number("noise/linear_velocity_noise", noise.linear_velocity_noise, Bound::kNonNegative);
  v.number("noise/angular_velocity_noise", noise.angular_velocity_noise, Bound::kNonNegative);
  v.flag("noise/use_message_covariance", noise.use_message_covariance);
  v.flag("noise/estimate_twist_noise", noise.estimate_twist_noise);
  v.integer("noise/twist_noise_window", noise.twist_noise_window, Bound::kAtLeastOne);
  v.integer("noise/twist_noise_min_samples", noise.twist_noise_min_samples, Bound::kAtLeastOne);
  v.flag("noise/report_track_correlation", noise.report_track_correlation);
  v.number("noise/twist_speed_scale_sigma", noise.twist_speed_scale_sigma, Bound::kNonNegative);
  v.flag("noise/count_observed_speed_error", noise.count_observed_speed_error);
  v.integer("noise/track_correlation_window", noise.track_correlation_window, Bound::kAtLeastOne);
  v.number("noise/track_correlation_max", noise.track_correlation_max, Bound::kOpenUnit);

  v.number("prior/position_sigma", o.prior.position_sigma, Bound::kPositive);
  v.number("prior/rotation_sigma", o.prior.rotation_sigma, Bound::kPositive);

  auto& bias = o.bias;
  v.flag("bias/estimate_gyro_bias", bias.estimate_gyro_bias);
  v.number("bias/gyro_prior_sigma", bias.gyro_prior_sigma, Bound::kPositive);
  v.number("bias/gyro_random_walk", bias.gyro_random_walk, Bound::kNonNegative);
  v.flag("bias/estimate_velocity_bias", bias.estimate_velocity_bias);
  v.number("bias/velocity_prior_sigma", bias.velocity_prior_sigma, Bound::kPositive);
  v.number("bias/velocity_random_walk", bias.velocity_random_walk, Bound::kNonNegative);
  v.flag("bias/estimate_speed_scale", bias.estimate_speed_scale);
  v.number("bias/speed_scale_prior_sigma", bias.speed_scale_prior_sigma, Bound::kPositive);
  v.number("bias/speed_scale_random_walk", bias.speed_scale_random_walk, Bound::kNonNegative);

  auto& extrinsic = o.extrinsic;
  v.flag("extrinsic/estimate_twist_rotation", extrinsic.estimate_twist_rotation);
  v.number("extrinsic/twist_rotation_prior_sigma", extrinsic.twist_rotation_prior_sigma,
           Bound::kPositive);
  v.number("extrinsic/twist_rotation_random_walk", extrinsic.twist_rotation_random_walk,
           Bound::kNonNegative);
  v.number("extrinsic/camera_time_offset", extrinsic.camera_time_offset, Bound::kAny);

  auto& intrinsic = o.intrinsic;
  v.flag("intrinsic/estimate_disparity_offset", intrinsic.estimate_disparity_offset);
  v.number("intrinsic/disparity_offset_prior_sigma", intrinsic.disparity_offset_prior_sigma,
           Bound::kPositive);
  v.number("intrinsic/disparity_offset_random_walk", intrinsic.disparity_offset_random_walk,
           Bound::kNonNegative);
  v.number("intrinsic/disparity_offset_counted_sigma", intrinsic.disparity_offset_counted_sigma,
           Bound::kNonNegative);
  v.flag("intrinsic/count_shown_disparity_offset", intrinsic.count_shown_disparity_offset);
  v.flag("intrinsic/estimate_baseline_scale", intrinsic.estimate_baseline_scale);
  v.number("intrinsic/baseline_scale_prior_sigma", intrinsic.baseline_scale_prior_sigma,
           Bound::kPositive);
  v.number("intrinsic/baseline_scale_random_walk", intrinsic.baseline_scale_random_walk,
           Bound::kNonNegative);

  auto& drift = o.track_drift;
  v.flag("track_drift/estimate_rate", drift.estimate_rate);
  v.number("track_drift/rate_prior_sigma", drift.rate_prior_sigma, Bound::kPositive);
  v.number("track_drift/rate_random_walk", drift.rate_random_walk, Bound::kNonNegative);

  v.number("vehicle/lateral_velocity_sigma", o.vehicle.lateral_velocity_sigma, Bound::kNonNegative);
  v.number("vehicle/vertical_velocity_sigma", o.vehicle.vertical_velocity_sigma,
           Bound::kNonNegative);
  v.number("vehicle/tilt_sigma", o.vehicle.tilt_sigma, Bound::kNonNegative);
  v.number("vehicle/tilt_correlation_distance", o.vehicle.tilt_correlation_distance,
           Bound::kPositive);
  v.number("vehicle/body_tilt_sigma", o.vehicle.body_tilt_sigma, Bound::kPositive);
  v.number("vehicle/tilt_update_period", o.vehicle.tilt_update_period, Bound::kPositive);
  v.flag("vehicle/count_shown_tilt_error", o.vehicle.count_shown_tilt_error);

  auto& gravity = o.gravity;
  v.flag("gravity/enabled", gravity.enabled);
  v.number("gravity/window", gravity.window, Bound::kPositive);
  v.number("gravity/magnitude", gravity.magnitude, Bound::kPositive);
  v.number("gravity/level_sigma", gravity.level_sigma, Bound::kPositive);
  v.number("gravity/accel_bias_sigma", gravity.accel_bias_sigma, Bound::kPositive);
  v.number("gravity/accel_bias_random_walk", gravity.accel_bias_random_walk, Bound::kNonNegative);
  v.number("gravity/accel_noise_density", gravity.accel_noise_density, Bound::kPositive);

  auto& landmarks = o.landmarks;
  v.number("landmarks/min_disparity_px", landmarks.min_disparity_px, Bound::kPositive);
  v.number("landmarks/min_depth", landmarks.min_depth, Bound::kPositive);
  v.number("landmarks/max_depth", landmarks.max_depth, Bound::kPositive);
  v.number("landmarks/gating_probability", landmarks.gating_probability, Bound::kOpenUnit);
  v.integer("landmarks/reinitialize_after_gated", landmarks.reinitialize_after_gated,
            Bound::kNonNegative);
  v.integer("landmarks/max_restarts", landmarks.max_restarts, Bound::kNonNegative);
  v.flag("landmarks/prediction_check", landmarks.prediction_check);
  v.integer("landmarks/max_track_length", landmarks.max_track_length, Bound::kNonNegative);
  v.number("landmarks/jump_threshold_px", landmarks.jump_threshold_px, Bound::kNonNegative);
  v.number("landmarks/jump_threshold_sigmas", landmarks.jump_threshold_sigmas, Bound::kPositive);
  v.flag("landmarks/keep_all_in_state", landmarks.keep_all_in_state);
  v.integer("landmarks/max_track_gap", landmarks.max_track_gap, Bound::kNonNegative);
  v.integer("landmarks/max_active", landmarks.max_active, Bound::kNonNegative);
  v.flag("landmarks/inverse_depth_correction", landmarks.inverse_depth_correction);

  auto& limits = o.limits;
  v.number("limits/max_linear_speed", limits.max_linear_speed, Bound::kPositive);
  v.number("limits/max_angular_speed", limits.max_angular_speed, Bound::kPositive);
  v.number("limits/max_twist_gap", limits.max_twist_gap, Bound::kPositive);
  v.choice("limits/gap_policy", limits.gap_policy, kGapPolicyNames);
  v.number("limits/gap_noise_scale", limits.gap_noise_scale, Bound::kPositive);
  v.number("limits/max_row_difference_px", limits.max_row_difference_px, Bound::kPositive);
  v.choice("limits/repeated_frames", limits.repeated_frames, kRepeatedFrameNames);
  v.number("limits/repeated_frame_depth_sigma", limits.repeated_frame_depth_sigma,
           Bound::kNonNegative);
  v.integer("limits/max_features_per_frame", limits.max_features_per_frame, Bound::kNonNegative);

  auto& standstill = o.standstill;
  v.flag("standstill/enabled", standstill.enabled);
  v.number("standstill/max_displacement_px", standstill.max_displacement_px, Bound::kPositive);
  v.integer("standstill/min_tracks", standstill.min_tracks, Bound::kAtLeastOne);
  v.number("standstill/max_twist_speed", standstill.max_twist_speed, Bound::kNonNegative);

  auto& health = o.health;
  v.number("health/max_position_sigma", health.max_position_sigma, Bound::kPositive);
  v.integer("health/max_rejected_frames", health.max_rejected_frames, Bound::kAtLeastOne);
  v.number("health/rejected_fraction", health.rejected_fraction, Bound::kUnitFraction);
  v.choice("health/divergence_policy", health.divergence_policy, kDivergenceNames);
}

constexpr auto kTable = [](auto& options, auto& visitor) { visitVislamOptions(options, visitor); };

}  // namespace

const char* modeName(EstimatorMode mode) { return enumName(kModeNames, mode); }

bool parseMode(const std::string& name, EstimatorMode* mode) {
  for (const auto& [mode_name, value] : kModeNames) {
    if (name == mode_name) {
      *mode = value;
      return true;
    }
  }
  return false;
}

std::string VislamOptions::validate() const {
  OptionValidator validator;
  visitVislamOptions(*this, validator);
  if (landmarks.max_depth <= landmarks.min_depth) {
    validator.fail("'landmarks/max_depth' must exceed 'landmarks/min_depth'");
  }
  return validator.error();
}

bool parseVislamOptions(const ParameterSource& source, VislamOptions* options, std::string* error) {
  OptionReader reader(source, error);
  VislamOptions o = *options;
  visitVislamOptions(o, reader);
  if (!reader.ok()) return false;
  const std::string why = o.validate();
  if (!why.empty()) {
    if (error != nullptr) *error = source.describe() + ": " + why;
    return false;
  }
  *options = o;
  return true;
}

std::string describeOptions(const VislamOptions& options) {
  return describeOptionTable(options, kTable);
}

std::vector<OptionKeyList::Key> vislamOptionKeys() {
  return optionTableKeys<VislamOptions>(kTable);
}

}  // namespace ekf_vislam
