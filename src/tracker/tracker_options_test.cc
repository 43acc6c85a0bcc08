#include "ekf_vislam/tracker/tracker_options.h"
#include "ekf_vislam/core/yaml_parameter_source.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(TrackerOptions, ShippedFileEqualsTheDefaults) {
  YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/tracker.yaml");
  ASSERT_TRUE(source.ok()) << source.error();
  const std::vector<OptionKeyList::Key> keys = trackerOptionKeys();
  EXPECT_EQ(keys.size(), 44u);
  for (const OptionKeyList::Key& key : keys) {
    EXPECT_TRUE(source.has(key.name)) << key.name << " is not documented in config/tracker.yaml";
  }
  TrackerOptions options;
  std::string error;
  ASSERT_TRUE(parseTrackerOptions(source, &options, &error)) << error;
  EXPECT_EQ(options.validate(), "");
  EXPECT_EQ(describeOptions(options), describeOptions(TrackerOptions()));
}

TEST(TrackerOptions, ShippedFileHasNoUnknownKeyAndATypoIsNamed) {
  YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/tracker.yaml");
  ASSERT_TRUE(source.ok()) << source.error();
  EXPECT_EQ(unknownTrackerKeys(source), "");
  EXPECT_EQ(unknownTrackerKeys(YamlParameterSource::fromString(
                "ros: {use_twist: true, queue_sise: 3}\ndetector: {grid_cols: 4}\n")),
            "unknown key ignored: ros/queue_sise (ros/queue_size?)");
}

TEST(TrackerRosOptions, ShippedFileEqualsTheDefaultsAndRangesAreChecked) {
  YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/tracker.yaml");
  ASSERT_TRUE(source.ok()) << source.error();
  const std::vector<OptionKeyList::Key> keys = trackerRosOptionKeys();
  EXPECT_EQ(keys.size(), 11u);
  for (const OptionKeyList::Key& key : keys) {
    EXPECT_TRUE(source.has(key.name)) << key.name << " is not documented in config/tracker.yaml";
  }
  StereoTrackerRosOptions options;
  std::string error;
  ASSERT_TRUE(parseTrackerRosOptions(source, &options, &error)) << error;
  EXPECT_EQ(options.queue_size, 200);
  EXPECT_EQ(options.max_backlog_mb, StereoTrackerRosOptions().max_backlog_mb);
  EXPECT_TRUE(options.use_twist);
  EXPECT_EQ(options.image_transport, ImageTransportType::kRaw);
  EXPECT_FALSE(options.rectify);
  EXPECT_EQ(options.image_bits, 0);
  const YamlParameterSource changed = YamlParameterSource::fromString(
      "ros: {queue_size: 7, use_twist: false, image_transport: compressed, rectify: true, "
      "image_bits: 12}\n");
  ASSERT_TRUE(parseTrackerRosOptions(changed, &options, &error)) << error;
  EXPECT_EQ(options.queue_size, 7);
  EXPECT_FALSE(options.use_twist);
  EXPECT_EQ(options.image_transport, ImageTransportType::kCompressed);
  EXPECT_TRUE(options.rectify);
  EXPECT_EQ(options.image_bits, 12);
  // Each range the nodelet has always checked: the options stay as they were.
  for (const char* bad :
       {"ros: {queue_size: 0}\n", "ros: {max_stamp_difference: -0.1}\n",
        "ros: {max_twist_wait: -1}\n", "ros: {time_jump_reset: -1}\n",
        "ros: {diagnostic_period: 0}\n", "ros: {twist_type: imu}\n", "ros: {max_backlog_mb: 0}\n",
        "ros: {image_transport: theora}\n", "ros: {image_bits: 7}\n", "ros: {image_bits: 17}\n"}) {
    error.clear();
    EXPECT_FALSE(parseTrackerRosOptions(YamlParameterSource::fromString(bad), &options, &error))
        << bad;
    EXPECT_NE(error.find("ros/"), std::string::npos) << error;
    EXPECT_EQ(options.queue_size, 7);
  }
}

TEST(TrackerOptions, ParsesAndRejects) {
  TrackerOptions options;
  std::string error;
  ASSERT_TRUE(parseTrackerOptions(
      YamlParameterSource::fromString("detector: {type: shi_tomasi, grid_cols: 4}\n"
                                      "ransac: {type: fundamental, threshold_px: 2.5}\n"),
      &options, &error));
  EXPECT_EQ(options.detector, FeatureDetectorType::kShiTomasi);
  EXPECT_EQ(options.grid_cols, 4);
  EXPECT_EQ(options.outlier_check, TemporalOutlierCheck::kFundamental);
  EXPECT_DOUBLE_EQ(options.ransac_threshold_px, 2.5);

  EXPECT_FALSE(parseTrackerOptions(YamlParameterSource::fromString("ransac: {type: lmeds}\n"),
                                   &options, &error));
  EXPECT_NE(error.find("ransac/type"), std::string::npos) << error;
  EXPECT_FALSE(parseTrackerOptions(YamlParameterSource::fromString("klt: {window_size: big}\n"),
                                   &options, &error));

  // Each unusable value is refused with its key; one test per check a bound cannot express.
  struct Case {
    void (*spoil)(TrackerOptions*);
    const char* key;
  };
  for (const Case& c :
       {Case{[](TrackerOptions* o) { o->window_size = 20; }, "klt/window_size"},
        Case{[](TrackerOptions* o) { o->min_disparity_px = 0; }, "stereo/min_disparity_px"},
        Case{[](TrackerOptions* o) { o->max_disparity_px = 0.4; }, "stereo/max_disparity_px"},
        Case{[](TrackerOptions* o) { o->fast_threshold = 300; }, "detector/fast_threshold"},
        Case{[](TrackerOptions* o) { o->min_ransac_points = 5; }, "ransac/min_points"},
        Case{[](TrackerOptions* o) { o->ransac_confidence = 1.0; }, "ransac/confidence"},
        Case{[](TrackerOptions* o) { o->refine_patch_size = 14; }, "refine/patch_size"},
        Case{[](TrackerOptions* o) { o->refine_min_zncc = 1.5; }, "refine/min_zncc"},
        Case{[](TrackerOptions* o) { o->max_rate_hz = -1; }, "input/max_rate_hz"},
        Case{[](TrackerOptions* o) { o->refine_max_scale_change = 1.0; },
             "refine/max_scale_change"}}) {
    TrackerOptions bad;
    c.spoil(&bad);
    EXPECT_NE(bad.validate().find(c.key), std::string::npos) << c.key << ": " << bad.validate();
  }
  // A refused file changes nothing.
  TrackerOptions unchanged;
  EXPECT_FALSE(parseTrackerOptions(
      YamlParameterSource::fromString("detector: {grid_cols: 3}\nransac: {type: lmeds}\n"),
      &unchanged, &error));
  EXPECT_EQ(unchanged.grid_cols, TrackerOptions().grid_cols);
}

}  // namespace
}  // namespace ekf_vislam
