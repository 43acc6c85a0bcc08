#include "ekf_vislam/core/vislam_options.h"

#include "ekf_vislam/core/option_reader.h"

#include <cmath>
#include <sstream>

namespace ekf_vislam {

const char* modeName(EstimatorMode mode) {
  switch (mode) {
    case EstimatorMode::kDeadReckoning: return "deadreckoning";
    case EstimatorMode::kMapping: return "mapping";
    case EstimatorMode::kSlam: return "slam";
  }
  return "unknown";
}

bool parseMode(const std::string& name, EstimatorMode* mode) {
  for (EstimatorMode m :
       {EstimatorMode::kDeadReckoning, EstimatorMode::kMapping, EstimatorMode::kSlam}) {
    if (name == modeName(m)) {
      *mode = m;
      return true;
    }
  }
  return false;
}

namespace {


}  // namespace

std::string VislamOptions::validate() const {
  std::ostringstream why;
  auto positive = [&why](const char* key, double v) {
    if (!(v > 0.0) && why.str().empty()) why << "'" << key << "' must be positive (" << v << ")";
  };
  auto non_negative = [&why](const char* key, double v) {
    if (!(v >= 0.0) && why.str().empty()) why << "'" << key << "' must be >= 0 (" << v << ")";
  };
  positive("noise/pixel_sigma", pixel_sigma);
  non_negative("noise/linear_velocity_noise", linear_velocity_noise);
  non_negative("noise/angular_velocity_noise", angular_velocity_noise);
  positive("prior/position_sigma", prior_position_sigma);
  positive("prior/rotation_sigma", prior_rotation_sigma);
  positive("bias/gyro_prior_sigma", gyro_bias_prior_sigma);
  non_negative("bias/gyro_random_walk", gyro_bias_random_walk);
  positive("bias/velocity_prior_sigma", velocity_bias_prior_sigma);
  non_negative("bias/velocity_random_walk", velocity_bias_random_walk);
  positive("extrinsic/twist_rotation_prior_sigma", twist_rotation_prior_sigma);
  non_negative("extrinsic/twist_rotation_random_walk", twist_rotation_random_walk);
  positive("intrinsic/disparity_offset_prior_sigma", disparity_offset_prior_sigma);
  non_negative("intrinsic/disparity_offset_random_walk", disparity_offset_random_walk);
  positive("intrinsic/baseline_scale_prior_sigma", baseline_scale_prior_sigma);
  non_negative("intrinsic/baseline_scale_random_walk", baseline_scale_random_walk);
  non_negative("vehicle/lateral_velocity_sigma", lateral_velocity_sigma);
  non_negative("vehicle/vertical_velocity_sigma", vertical_velocity_sigma);
  positive("landmarks/min_disparity_px", min_disparity_px);
  positive("landmarks/min_depth", min_depth);
  positive("landmarks/max_depth", max_depth);
  non_negative("landmarks/jump_threshold_px", jump_threshold_px);
  positive("landmarks/jump_threshold_sigmas", jump_threshold_sigmas);
  positive("limits/max_linear_speed", max_linear_speed);
  positive("limits/max_angular_speed", max_angular_speed);
  positive("limits/max_twist_gap", max_twist_gap);
  positive("limits/gap_noise_scale", gap_noise_scale);
  positive("limits/max_row_difference_px", max_row_difference_px);
  positive("health/max_position_sigma", max_position_sigma);
  if (why.str().empty()) {
    if (max_depth <= min_depth) {
      why << "'landmarks/max_depth' must exceed 'landmarks/min_depth'";
    } else if (!(gating_probability > 0.0 && gating_probability < 1.0)) {
      why << "'landmarks/gating_probability' must be in (0, 1)";
    } else if (reinitialize_after_gated < 0) {
      why << "'landmarks/reinitialize_after_gated' must be >= 0";
    } else if (max_track_length < 0) {
      why << "'landmarks/max_track_length' must be >= 0";
    } else if (max_track_gap < 0) {
      why << "'landmarks/max_track_gap' must be >= 0";
    } else if (max_features_per_frame < 0) {
      why << "'limits/max_features_per_frame' must be >= 0";
    } else if (max_rejected_frames < 1) {
      why << "'health/max_rejected_frames' must be >= 1";
    } else if (!(rejected_fraction > 0.0 && rejected_fraction <= 1.0)) {
      why << "'health/rejected_fraction' must be in (0, 1]";
    }
  }
  return why.str();
}

bool parseVislamOptions(const ParameterSource& source, VislamOptions* o, std::string* error) {
  OptionReader r(source, error);
  r.choice("mode", &o->mode,
           {{"deadreckoning", EstimatorMode::kDeadReckoning},
            {"mapping", EstimatorMode::kMapping},
            {"slam", EstimatorMode::kSlam}});
  r.number("noise/pixel_sigma", &o->pixel_sigma);
  r.flag("noise/use_message_covariance", &o->use_message_covariance);
  r.flag("noise/merge_stereo_rows", &o->merge_stereo_rows);
  r.number("noise/linear_velocity_noise", &o->linear_velocity_noise);
  r.number("noise/angular_velocity_noise", &o->angular_velocity_noise);
  r.number("prior/position_sigma", &o->prior_position_sigma);
  r.number("prior/rotation_sigma", &o->prior_rotation_sigma);
  r.flag("bias/estimate_gyro_bias", &o->estimate_gyro_bias);
  r.number("bias/gyro_prior_sigma", &o->gyro_bias_prior_sigma);
  r.number("bias/gyro_random_walk", &o->gyro_bias_random_walk);
  r.flag("bias/estimate_velocity_bias", &o->estimate_velocity_bias);
  r.number("bias/velocity_prior_sigma", &o->velocity_bias_prior_sigma);
  r.number("bias/velocity_random_walk", &o->velocity_bias_random_walk);
  r.flag("extrinsic/estimate_twist_rotation", &o->estimate_twist_rotation);
  r.number("extrinsic/twist_rotation_prior_sigma", &o->twist_rotation_prior_sigma);
  r.number("extrinsic/twist_rotation_random_walk", &o->twist_rotation_random_walk);
  r.flag("intrinsic/estimate_disparity_offset", &o->estimate_disparity_offset);
  r.number("intrinsic/disparity_offset_prior_sigma", &o->disparity_offset_prior_sigma);
  r.number("intrinsic/disparity_offset_random_walk", &o->disparity_offset_random_walk);
  r.flag("intrinsic/estimate_baseline_scale", &o->estimate_baseline_scale);
  r.number("intrinsic/baseline_scale_prior_sigma", &o->baseline_scale_prior_sigma);
  r.number("intrinsic/baseline_scale_random_walk", &o->baseline_scale_random_walk);
  r.number("vehicle/lateral_velocity_sigma", &o->lateral_velocity_sigma);
  r.number("vehicle/vertical_velocity_sigma", &o->vertical_velocity_sigma);
  r.number("landmarks/min_disparity_px", &o->min_disparity_px);
  r.number("landmarks/min_depth", &o->min_depth);
  r.number("landmarks/max_depth", &o->max_depth);
  r.number("landmarks/gating_probability", &o->gating_probability);
  r.integer("landmarks/reinitialize_after_gated", &o->reinitialize_after_gated);
  r.integer("landmarks/max_track_length", &o->max_track_length);
  r.number("landmarks/jump_threshold_px", &o->jump_threshold_px);
  r.number("landmarks/jump_threshold_sigmas", &o->jump_threshold_sigmas);
  r.flag("landmarks/keep_all_in_state", &o->keep_all_landmarks_in_state);
  r.integer("landmarks/max_track_gap", &o->max_track_gap);
  r.number("limits/max_linear_speed", &o->max_linear_speed);
  r.number("limits/max_angular_speed", &o->max_angular_speed);
  r.number("limits/max_twist_gap", &o->max_twist_gap);
  r.choice("limits/gap_policy", &o->gap_policy,
           {{"predict", GapPolicy::kPredict}, {"reset", GapPolicy::kReset}});
  r.number("limits/gap_noise_scale", &o->gap_noise_scale);
  r.number("limits/max_row_difference_px", &o->max_row_difference_px);
  r.choice("limits/repeated_frames", &o->repeated_frames,
           {{"use", RepeatedFramePolicy::kUse},
            {"skip", RepeatedFramePolicy::kSkip},
            {"shift", RepeatedFramePolicy::kShift}});
  r.number("limits/repeated_frame_depth_sigma", &o->repeated_frame_depth_sigma);
  r.integer("limits/max_features_per_frame", &o->max_features_per_frame);
  r.number("health/max_position_sigma", &o->max_position_sigma);
  r.integer("health/max_rejected_frames", &o->max_rejected_frames);
  r.number("health/rejected_fraction", &o->rejected_fraction);
  r.choice("health/divergence_policy", &o->divergence_policy,
           {{"reset_landmarks", DivergencePolicy::kResetLandmarks},
            {"reset_filter", DivergencePolicy::kResetFilter}});
  if (!r.ok()) return false;
  const std::string why = o->validate();
  if (!why.empty()) {
    if (error != nullptr) *error = source.describe() + ": " + why;
    return false;
  }
  return true;
}

}  // namespace ekf_vislam
