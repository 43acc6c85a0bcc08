#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/tracker/tracker_options.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(TrackerOptions, ShippedFileEqualsTheDefaults) {
  YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/tracker.yaml");
  ASSERT_TRUE(source.ok()) << source.error();
  TrackerOptions options;
  std::string error;
  ASSERT_TRUE(parseTrackerOptions(source, &options, &error)) << error;
  EXPECT_EQ(options.validate(), "");
  EXPECT_EQ(describeOptions(options), describeOptions(TrackerOptions()));
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

  TrackerOptions bad;
  bad.window_size = 20;
  bad.min_disparity_px = 0;
  const std::string why = bad.validate();
  EXPECT_NE(why.find("klt/window_size"), std::string::npos);
  EXPECT_NE(why.find("stereo/min_disparity_px"), std::string::npos);
}

}  // namespace
}  // namespace ekf_vislam
