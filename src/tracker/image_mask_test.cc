#include "ekf_vislam/tracker/image_mask.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <fstream>
#include <string>

namespace ekf_vislam {
namespace {

TEST(ImageMask, LoadsTheNamedImagesAndNamesTheKeyOfOneItCannotRead) {
  const std::string path = ::testing::TempDir() + "ekf_vislam_mask_left.png";
  cv::Mat written(40, 60, CV_8UC1, cv::Scalar(255));
  written(cv::Rect(30, 0, 30, 40)).setTo(0);  // right half masked
  ASSERT_TRUE(cv::imwrite(path, written));

  TrackerOptions options;
  options.mask_left = path;
  StereoMasks masks;
  std::string error;
  ASSERT_TRUE(loadStereoMasks(options, &masks, &error)) << error;
  ASSERT_EQ(masks.left.size(), cv::Size(60, 40));
  EXPECT_EQ(masks.left.type(), CV_8UC1);
  EXPECT_TRUE(masks.right.empty());
  EXPECT_TRUE(usablePixel(masks.left, cv::Point2f(29.4f, 10.f)));
  EXPECT_FALSE(usablePixel(masks.left, cv::Point2f(29.6f, 10.f)));     // nearest pixel 30
  EXPECT_FALSE(usablePixel(masks.left, cv::Point2f(-1.f, 10.f)));      // outside
  EXPECT_TRUE(usablePixel(masks.right, cv::Point2f(1000.f, 1000.f)));  // no mask

  options.mask_right = ::testing::TempDir() + "ekf_vislam_no_such_mask.png";
  EXPECT_FALSE(loadStereoMasks(options, &masks, &error));
  EXPECT_NE(error.find("'mask/right'"), std::string::npos) << error;
  EXPECT_NE(error.find("ekf_vislam_no_such_mask.png"), std::string::npos) << error;
  EXPECT_FALSE(masks.left.empty());  // unchanged on failure

  options.mask_right = path + ".txt";  // a file, not an image
  { std::ofstream(options.mask_right) << "not an image\n"; }
  EXPECT_FALSE(loadStereoMasks(options, &masks, &error));
  EXPECT_EQ(error, "'mask/right': not an image OpenCV reads: " + options.mask_right);
  std::remove(options.mask_right.c_str());
  std::remove(path.c_str());
}

TEST(ImageMask, SizesAreCheckedAndMaskedPointsRefused) {
  StereoMasks masks;
  EXPECT_EQ(checkMaskSizes(masks, cv::Size(640, 480)), "");
  masks.right = cv::Mat(480, 640, CV_8UC1, cv::Scalar(1));
  masks.right(cv::Rect(0, 0, 640, 100)).setTo(0);  // top rows masked
  EXPECT_EQ(checkMaskSizes(masks, cv::Size(640, 480)), "");
  EXPECT_EQ(checkMaskSizes(masks, cv::Size(1241, 376)),
            "the 'mask/right' image is 640x480, the camera images 1241x376");

  const std::vector<cv::Point2f> points = {{10, 50}, {10, 150}, {600, 99}, {600, 101}};
  std::vector<uint8_t> ok = {1, 1, 0, 1};
  EXPECT_EQ(refuseMaskedPoints(masks.right, points, &ok), 1);  // the third was refused already
  EXPECT_EQ(ok, (std::vector<uint8_t>{0, 1, 0, 1}));
  EXPECT_EQ(refuseMaskedPoints(cv::Mat(), points, &ok), 0);
}

}  // namespace
}  // namespace ekf_vislam
