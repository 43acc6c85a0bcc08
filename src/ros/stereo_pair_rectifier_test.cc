#include "ekf_vislam/ros/stereo_pair_rectifier.h"

#include "testing/blurred_texture.h"
#include "testing/raw_camera_image.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace ekf_vislam {
namespace {

// A raw stereo pair's camera_info at the sensor's full 1241x376: plumb_bob with a strong barrel
// and a rectifying turn of 0.5 degrees, the right camera 0.54 m to the right (P[3]).
sensor_msgs::CameraInfo fullCameraInfo(bool right) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "camera_left";
  info.width = 1241;
  info.height = 376;
  info.distortion_model = "plumb_bob";
  info.D = {-0.30, 0.12, 4e-4, -6e-4, -0.02};
  info.K = {718.0, 0.0, 615.0, 0.0, 716.0, 181.0, 0.0, 0.0, 1.0};
  const double a = 0.5 * M_PI / 180.0;
  info.R = {std::cos(a), 0.0, std::sin(a), 0.0, 1.0, 0.0, -std::sin(a), 0.0, std::cos(a)};
  info.P = {700.0, 0.0, 610.0, right ? -700.0 * 0.54 : 0.0, 0.0, 700.0, 186.0, 0.0, 0.0,
            0.0,   1.0, 0.0};
  return info;
}

struct Scene {
  cv::Mat truth;      ///< the rectified image at full resolution
  cv::Mat raw;        ///< what the raw camera takes of it
  cv::Mat rectified;  ///< raw rectified at full resolution
};

Scene fullResolutionScene() {
  Scene scene;
  scene.truth = testing::blurredTexture(cv::Size(1241, 376), 7, 3.0);
  ImageRectifier full;
  std::string why;
  EXPECT_TRUE(full.reset(rawCameraModel(fullCameraInfo(false)), &why)) << why;
  scene.raw = testing::rawImageOf(scene.truth, full);
  EXPECT_TRUE(full.rectify(scene.raw, &scene.rectified));
  return scene;
}

// Rectifies *image as the left image of a pair whose right image is the same (the right camera
// only has to be rectifiable here).
StereoPairRectifier::Result rectifyBoth(StereoPairRectifier* rectifier,
                                        const sensor_msgs::CameraInfo& left_info,
                                        const sensor_msgs::CameraInfo& right_info, cv::Mat* image,
                                        std::string* why) {
  cv::Mat right = image->clone();
  std_msgs::Header header;
  header.frame_id = "camera_left";
  std::optional<geometry_msgs::TransformStamped> transform;
  return rectifier->rectify(left_info, right_info, image, &right, &header, &transform, why);
}

double meanDifference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  return cv::mean(difference)[0];
}

// A driver's region of interest: the raw image is a crop of the sensor's, the camera_info the full
// calibration with the ROI. Rectified, it is the same crop of the full rectified image.
TEST(StereoPairRectifier, ARegionOfInterestGivesTheCropOfTheFullRectifiedImage) {
  const Scene scene = fullResolutionScene();
  const cv::Rect roi(200, 40, 640, 256);
  sensor_msgs::CameraInfo left_info = fullCameraInfo(false), right_info = fullCameraInfo(true);
  for (sensor_msgs::CameraInfo* info : {&left_info, &right_info}) {
    info->roi.x_offset = roi.x;
    info->roi.y_offset = roi.y;
    info->roi.width = roi.width;
    info->roi.height = roi.height;
  }
  cv::Mat left = scene.raw(roi).clone();
  StereoPairRectifier rectifier;
  std::string why;
  ASSERT_EQ(rectifyBoth(&rectifier, left_info, right_info, &left, &why),
            StereoPairRectifier::Result::kOk)
      << why;
  ASSERT_EQ(left.size(), roi.size());
  // Inside the crop (its rectified pixels seen by the raw crop): the full image's pixels.
  const cv::Rect inner(40, 30, roi.width - 80, roi.height - 60);
  const cv::Rect inner_in_full(roi.x + inner.x, roi.y + inner.y, inner.width, inner.height);
  EXPECT_LT(meanDifference(left(inner), scene.rectified(inner_in_full)), 0.05);
  // Ignoring the ROI (the full model on the crop) would be refused for its size; moved by the
  // offset instead, the crop is tens of gray levels off.
  EXPECT_GT(meanDifference(left(inner), scene.rectified(inner)), 10.0);
}

// A driver's 2x2 binning: the raw image is the sensor's averaged over 2x2 blocks. Rectified with
// the binned camera_info, it is the rectified scene at half resolution.
TEST(StereoPairRectifier, BinningGivesTheRectifiedSceneAtTheBinnedResolution) {
  const Scene scene = fullResolutionScene();
  sensor_msgs::CameraInfo left_info = fullCameraInfo(false), right_info = fullCameraInfo(true);
  left_info.binning_x = left_info.binning_y = right_info.binning_x = right_info.binning_y = 2;
  const cv::Size binned(1241 / 2, 376 / 2);
  cv::Mat left, truth;
  cv::resize(scene.raw(cv::Rect(0, 0, 2 * binned.width, 2 * binned.height)), left, binned, 0, 0,
             cv::INTER_AREA);
  cv::resize(scene.truth(cv::Rect(0, 0, 2 * binned.width, 2 * binned.height)), truth, binned, 0, 0,
             cv::INTER_AREA);
  StereoPairRectifier rectifier;
  std::string why;
  ASSERT_EQ(rectifyBoth(&rectifier, left_info, right_info, &left, &why),
            StereoPairRectifier::Result::kOk)
      << why;
  ASSERT_EQ(left.size(), binned);
  const cv::Rect inner(50, 30, binned.width - 100, binned.height - 60);
  EXPECT_LT(meanDifference(left(inner), truth(inner)), 2.0);

  // The full-resolution raw image with the binned camera_info: refused, both sizes named.
  cv::Mat full_left = scene.raw.clone();
  EXPECT_EQ(rectifyBoth(&rectifier, left_info, right_info, &full_left, &why),
            StereoPairRectifier::Result::kSizeMismatch);
  EXPECT_NE(why.find("1241x376"), std::string::npos) << why;
  EXPECT_NE(why.find("620x188"), std::string::npos) << why;
}

}  // namespace
}  // namespace ekf_vislam
