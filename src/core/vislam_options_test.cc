#include "ekf_vislam/core/vislam_options.h"

#include "ekf_vislam/core/yaml_parameter_source.h"

#include <gtest/gtest.h>

#include <sstream>
#include <vector>

namespace ekf_vislam {
namespace {

TEST(VislamOptions, ShippedConfigHasEveryKeyWithItsBuiltInDefault) {
  const YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_TRUE(source.ok()) << source.error();
  const std::vector<OptionKeyList::Key> keys = vislamOptionKeys();
  EXPECT_GE(keys.size(), 45u);
  for (const OptionKeyList::Key& key : keys) {
    EXPECT_TRUE(source.has(key.name)) << key.name << " is not documented in config/default.yaml";
  }
  VislamOptions parsed;
  std::string error;
  ASSERT_TRUE(parseVislamOptions(source, &parsed, &error)) << error;
  // The file documents the defaults: every value must agree (the description lists every key).
  EXPECT_EQ(describeOptions(parsed), describeOptions(VislamOptions()));
}

TEST(VislamOptions, DescriptionListsEveryKeyByGroup) {
  const std::string text = describeOptions(VislamOptions());
  for (const OptionKeyList::Key& key : vislamOptionKeys()) {
    const size_t slash = key.name.rfind('/');
    const std::string group = key.name.substr(0, slash == std::string::npos ? 0 : slash);
    const std::string name = key.name.substr(slash == std::string::npos ? 0 : slash + 1);
    EXPECT_NE(text.find(name + "="), std::string::npos) << key.name;
    if (!group.empty()) {
      EXPECT_NE(text.find(group + ":"), std::string::npos) << key.name;
    }
  }
  EXPECT_NE(text.find("limits: max_linear_speed=100 "), std::string::npos) << text;
  EXPECT_NE(text.find("repeated_frames=shift"), std::string::npos) << text;
}

TEST(VislamOptions, EveryBoundedKeyRejectsAValueOutsideItsRange) {
  int bounded = 0;
  for (const OptionKeyList::Key& key : vislamOptionKeys()) {
    if (key.bound == Bound::kAny) continue;
    ++bounded;
    const double outside = valueOutside(key.bound);
    const size_t slash = key.name.rfind('/');
    ASSERT_NE(slash, std::string::npos) << key.name;
    std::ostringstream yaml;
    yaml << key.name.substr(0, slash) << ":\n  " << key.name.substr(slash + 1) << ": " << outside
         << "\n";
    const YamlParameterSource source = YamlParameterSource::fromString(yaml.str());
    VislamOptions o;
    std::string error;
    EXPECT_FALSE(parseVislamOptions(source, &o, &error)) << yaml.str();
    EXPECT_NE(error.find(key.name), std::string::npos) << error;
  }
  EXPECT_GE(bounded, 35);
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
  EXPECT_DOUBLE_EQ(o.noise.pixel_sigma, 3.5);
  EXPECT_EQ(o.limits.gap_policy, GapPolicy::kReset);
  EXPECT_TRUE(o.landmarks.keep_all_in_state);
  EXPECT_DOUBLE_EQ(o.landmarks.max_depth,
                   VislamOptions().landmarks.max_depth);  // absent: default kept
}

TEST(VislamOptions, ErrorsNameTheKey) {
  struct Case {
    const char* yaml;
    const char* key;
  };
  for (const Case& c :
       {Case{"mode: fast\n", "mode"}, Case{"noise:\n  pixel_sigma: abc\n", "noise/pixel_sigma"},
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
    // A refused file changes nothing, not even the keys before the bad one.
    EXPECT_EQ(describeOptions(o), describeOptions(VislamOptions())) << c.yaml;
  }
  const YamlParameterSource partly_good = YamlParameterSource::fromString(
      "noise:\n  pixel_sigma: 3.0\nhealth:\n  divergence_policy: panic\n");
  VislamOptions o;
  std::string error;
  EXPECT_FALSE(parseVislamOptions(partly_good, &o, &error));
  EXPECT_DOUBLE_EQ(o.noise.pixel_sigma, VislamOptions().noise.pixel_sigma);
}

TEST(VislamOptions, ModeNamesRoundTrip) {
  for (EstimatorMode m :
       {EstimatorMode::kDeadReckoning, EstimatorMode::kMapping, EstimatorMode::kSlam}) {
    EstimatorMode parsed;
    ASSERT_TRUE(parseMode(modeName(m), &parsed));
    EXPECT_EQ(parsed, m);
  }
  EstimatorMode unused;
  EXPECT_FALSE(parseMode("SLAM ", &unused));
}

TEST(YamlParameterSource, KeysAreTheLeavesOfTheMaps) {
  const YamlParameterSource source = YamlParameterSource::fromString(
      "mode: slam\nnoise: {pixel_sigma: 2, merge_stereo_rows: true}\n"
      "ros:\n  calibration: {fx: 700, cam_T_imu: [1, 0]}\n  empty:\n");
  EXPECT_EQ(source.keys(),
            (std::vector<std::string>{"mode", "noise/merge_stereo_rows", "noise/pixel_sigma",
                                      "ros/calibration/cam_T_imu", "ros/calibration/fx"}));
}

TEST(ParameterSource, UnknownKeysAreNamedWithTheNearestKnownOne) {
  const YamlParameterSource source = YamlParameterSource::fromString(
      "noise: {pixel_sigma: 2, pixl_sigma: 3}\nvehicle: {tilt_sigm: 0}\n"
      "ros: {calibration: {fx: 700}}\nsomething_else: 1\n");
  std::vector<std::string> known;
  appendKeyNames(vislamOptionKeys(), &known);
  const std::vector<std::string> unknown = unknownKeys(source, known, {"ros/calibration/"});
  EXPECT_EQ(unknown,
            (std::vector<std::string>{"noise/pixl_sigma", "something_else", "vehicle/tilt_sigm"}));
  EXPECT_EQ(describeUnknownKeys(unknown, known),
            "unknown keys ignored: noise/pixl_sigma (noise/pixel_sigma?), something_else, "
            "vehicle/tilt_sigm (vehicle/tilt_sigma?)");
  EXPECT_EQ(describeUnknownKeys({}, known), "");
  // The shipped file holds the core's keys and the ROS layer's (ros/): none of the core's is
  // unknown to it.
  const YamlParameterSource shipped(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/default.yaml");
  for (const std::string& key : unknownKeys(shipped, known)) {
    EXPECT_EQ(key.rfind("ros/", 0), 0u) << key;
  }
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
