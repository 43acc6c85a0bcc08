#include "ekf_vislam/core/vislam_options.h"

#include "ekf_vislam/core/yaml_parameter_source.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(VislamOptions, ShippedConfigParsesAndMatchesBuiltInDefaults) {
  const YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_TRUE(source.ok()) << source.error();
  VislamOptions parsed;
  // Start the newer keys away from their defaults: the file itself must set them.
  parsed.estimate_disparity_offset = !parsed.estimate_disparity_offset;
  parsed.disparity_offset_prior_sigma = 7.0;
  parsed.estimate_baseline_scale = !parsed.estimate_baseline_scale;
  parsed.baseline_scale_prior_sigma = 7.0;
  parsed.lateral_velocity_sigma = parsed.vertical_velocity_sigma = 7.0;
  parsed.max_track_length = 77;
  parsed.repeated_frames = RepeatedFramePolicy::kUse;
  parsed.repeated_frame_depth_sigma = 7.0;
  std::string error;
  ASSERT_TRUE(parseVislamOptions(source, &parsed, &error)) << error;
  // The file documents the defaults: both must agree.
  const VislamOptions defaults;
  EXPECT_EQ(parsed.estimate_disparity_offset, defaults.estimate_disparity_offset);
  EXPECT_DOUBLE_EQ(parsed.disparity_offset_prior_sigma, defaults.disparity_offset_prior_sigma);
  EXPECT_DOUBLE_EQ(parsed.disparity_offset_random_walk, defaults.disparity_offset_random_walk);
  EXPECT_EQ(parsed.estimate_baseline_scale, defaults.estimate_baseline_scale);
  EXPECT_DOUBLE_EQ(parsed.baseline_scale_prior_sigma, defaults.baseline_scale_prior_sigma);
  EXPECT_DOUBLE_EQ(parsed.baseline_scale_random_walk, defaults.baseline_scale_random_walk);
  EXPECT_DOUBLE_EQ(parsed.lateral_velocity_sigma, defaults.lateral_velocity_sigma);
  EXPECT_DOUBLE_EQ(parsed.vertical_velocity_sigma, defaults.vertical_velocity_sigma);
  EXPECT_EQ(parsed.max_track_length, defaults.max_track_length);
  EXPECT_EQ(parsed.mode, defaults.mode);
  EXPECT_DOUBLE_EQ(parsed.pixel_sigma, defaults.pixel_sigma);
  EXPECT_EQ(parsed.merge_stereo_rows, defaults.merge_stereo_rows);
  EXPECT_DOUBLE_EQ(parsed.linear_velocity_noise, defaults.linear_velocity_noise);
  EXPECT_DOUBLE_EQ(parsed.angular_velocity_noise, defaults.angular_velocity_noise);
  EXPECT_DOUBLE_EQ(parsed.prior_position_sigma, defaults.prior_position_sigma);
  EXPECT_DOUBLE_EQ(parsed.gyro_bias_prior_sigma, defaults.gyro_bias_prior_sigma);
  EXPECT_DOUBLE_EQ(parsed.gyro_bias_random_walk, defaults.gyro_bias_random_walk);
  EXPECT_EQ(parsed.estimate_gyro_bias, defaults.estimate_gyro_bias);
  EXPECT_EQ(parsed.estimate_velocity_bias, defaults.estimate_velocity_bias);
  EXPECT_DOUBLE_EQ(parsed.max_depth, defaults.max_depth);
  EXPECT_DOUBLE_EQ(parsed.gating_probability, defaults.gating_probability);
  EXPECT_EQ(parsed.reinitialize_after_gated, defaults.reinitialize_after_gated);
  EXPECT_DOUBLE_EQ(parsed.max_row_difference_px, defaults.max_row_difference_px);
  EXPECT_EQ(parsed.max_features_per_frame, defaults.max_features_per_frame);
  EXPECT_EQ(parsed.repeated_frames, defaults.repeated_frames);
  EXPECT_DOUBLE_EQ(parsed.repeated_frame_depth_sigma, defaults.repeated_frame_depth_sigma);
  EXPECT_EQ(parsed.gap_policy, defaults.gap_policy);
  EXPECT_EQ(parsed.divergence_policy, defaults.divergence_policy);
  EXPECT_EQ(parsed.estimate_twist_rotation, defaults.estimate_twist_rotation);
  EXPECT_DOUBLE_EQ(parsed.twist_rotation_prior_sigma, defaults.twist_rotation_prior_sigma);
}

TEST(VislamOptions, NestedKeysEnumsAndMissingKeys) {
  const YamlParameterSource source = YamlParameterSource::fromString(
      "mode: mapping\nnoise:\n  pixel_sigma: 3.5\nlimits:\n  gap_policy: reset\n"
      "landmarks:\n  keep_all_in_state: true\n");
  ASSERT_TRUE(source.ok());
  VislamOptions o;
  std::string error;
  ASSERT_TRUE(parseVislamOptions(source, &o, &error)) << error;
  EXPECT_EQ(o.mode, EstimatorMode::kMapping);
  EXPECT_DOUBLE_EQ(o.pixel_sigma, 3.5);
  EXPECT_EQ(o.gap_policy, GapPolicy::kReset);
  EXPECT_TRUE(o.keep_all_landmarks_in_state);
  EXPECT_DOUBLE_EQ(o.max_depth, VislamOptions().max_depth);  // absent: default kept
}

TEST(VislamOptions, ErrorsNameTheKey) {
  struct Case {
    const char* yaml;
    const char* key;
  };
  for (const Case& c : {Case{"mode: fast\n", "mode"},
                        Case{"noise:\n  pixel_sigma: abc\n", "noise/pixel_sigma"},
                        Case{"noise:\n  pixel_sigma: -1\n", "noise/pixel_sigma"},
                        Case{"landmarks:\n  gating_probability: 1.5\n", "landmarks/gating_probability"},
                        Case{"limits:\n  max_features_per_frame: 2.5\n", "limits/max_features_per_frame"},
                        Case{"landmarks:\n  min_depth: 50\n  max_depth: 10\n", "landmarks/max_depth"},
                        Case{"health:\n  divergence_policy: panic\n", "health/divergence_policy"}}) {
    const YamlParameterSource source = YamlParameterSource::fromString(c.yaml);
    VislamOptions o;
    std::string error;
    EXPECT_FALSE(parseVislamOptions(source, &o, &error)) << c.yaml;
    EXPECT_NE(error.find(c.key), std::string::npos) << error;
  }
}

TEST(VislamOptions, ModeNamesRoundTrip) {
  for (EstimatorMode m : {EstimatorMode::kDeadReckoning, EstimatorMode::kMapping, EstimatorMode::kSlam}) {
    EstimatorMode parsed;
    ASSERT_TRUE(parseMode(modeName(m), &parsed));
    EXPECT_EQ(parsed, m);
  }
  EstimatorMode unused;
  EXPECT_FALSE(parseMode("SLAM ", &unused));
}

TEST(YamlParameterSource, MissingFileAndSyntaxErrorsAreReported) {
  const YamlParameterSource missing("/nonexistent/ekf_vislam.yaml");
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("/nonexistent/ekf_vislam.yaml"), std::string::npos);
  const YamlParameterSource broken = YamlParameterSource::fromString("noise: [1, 2\n");
  EXPECT_FALSE(broken.ok());
}

}  // namespace
}  // namespace ekf_vislam
