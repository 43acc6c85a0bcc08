// Unit tests of the stereo tracker's image input (no roscore).
#include "ekf_vislam/ros/gray_image.h"

#include "ekf_vislam/ros/conversions.h"

#include <sensor_msgs/image_encodings.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <boost/make_shared.hpp>

#include <vector>

namespace ekf_vislam {
namespace {

// A 4 x 3 image of `encoding` whose every pixel holds `pixel` (one byte per channel).
sensor_msgs::ImageConstPtr uniformImage(const std::string& encoding,
                                        const std::vector<uint8_t>& pixel) {
  auto msg = boost::make_shared<sensor_msgs::Image>();
  msg->encoding = encoding;
  msg->width = 4;
  msg->height = 3;
  msg->step = static_cast<uint32_t>(msg->width * pixel.size());
  for (uint32_t i = 0; i < msg->width * msg->height; ++i) {
    msg->data.insert(msg->data.end(), pixel.begin(), pixel.end());
  }
  return msg;
}

TEST(GrayImage, GrayAndColourEncodingsGiveTheGrayLevel) {
  // Pure blue and pure red differ in gray (0.114 against 0.299 of 255), so a channel order read
  // the wrong way round shows.
  const struct {
    const char* encoding;
    std::vector<uint8_t> pixel;
    int gray;
  } cases[] = {
      {"mono8", {77}, 77},           {"8UC1", {77}, 77},
      {"bgr8", {255, 0, 0}, 29},     {"rgb8", {0, 0, 255}, 29},
      {"bgra8", {255, 0, 0, 9}, 29}, {"rgba8", {0, 0, 255, 9}, 29},
      {"bgr8", {0, 0, 255}, 76},     {"rgba8", {255, 0, 0, 200}, 76},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.encoding);
    EXPECT_TRUE(isTrackableEncoding(c.encoding));
    cv::Mat gray;
    std::string why;
    const sensor_msgs::ImageConstPtr msg = uniformImage(c.encoding, c.pixel);
    ASSERT_TRUE(toGrayImage(msg, &gray, &why)) << why;
    ASSERT_EQ(gray.type(), CV_8UC1);
    ASSERT_EQ(gray.size(), cv::Size(4, 3));
    EXPECT_EQ(static_cast<int>(gray.at<uint8_t>(2, 3)), c.gray);
  }
}

// A colour image of a camera with a Bayer filter of `pattern` ("rggb": R at row 0 column 0, then
// G, G, B): each pixel keeps the one channel its filter passes.
sensor_msgs::ImageConstPtr bayerImage(const cv::Mat& bgr, const std::string& pattern) {
  auto msg = boost::make_shared<sensor_msgs::Image>();
  msg->encoding = "bayer_" + pattern + "8";
  msg->width = static_cast<uint32_t>(bgr.cols);
  msg->height = static_cast<uint32_t>(bgr.rows);
  msg->step = msg->width;
  const std::string channels = "bgr";
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; ++u) {
      const char filter = pattern[2 * (v % 2) + u % 2];
      msg->data.push_back(bgr.at<cv::Vec3b>(v, u)[channels.find(filter)]);
    }
  }
  return msg;
}

TEST(GrayImage, BayerImagesAreDemosaicedToTheColourImagesGray) {
  // Red well above blue, so that a pattern read with red and blue exchanged is 0.185 (R - B)
  // off, about 30 gray levels.
  cv::Mat bgr(60, 80, CV_8UC3);
  cv::randu(bgr, cv::Scalar(20, 80, 180), cv::Scalar(60, 160, 240));
  cv::GaussianBlur(bgr, bgr, cv::Size(0, 0), 4.0);
  cv::Mat expected;
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2GRAY);
  const cv::Rect inner(4, 4, 72, 52);
  for (const char* pattern : {"rggb", "bggr", "gbrg", "grbg"}) {
    SCOPED_TRACE(pattern);
    const sensor_msgs::ImageConstPtr msg = bayerImage(bgr, pattern);
    EXPECT_TRUE(isTrackableEncoding(msg->encoding));
    cv::Mat gray;
    std::string why;
    ASSERT_TRUE(toGrayImage(msg, &gray, &why)) << why;
    ASSERT_EQ(gray.type(), CV_8UC1);
    cv::Mat difference;
    cv::absdiff(gray(inner), expected(inner), difference);
    EXPECT_LT(cv::mean(difference)[0], 3.0);
  }
}

TEST(GrayImage, GrayImagesAreSharedNotCopied) {
  const sensor_msgs::ImageConstPtr msg = uniformImage("mono8", {5});
  cv::Mat gray;
  std::string why;
  ASSERT_TRUE(toGrayImage(msg, &gray, &why));
  EXPECT_EQ(gray.data, msg->data.data());
}

TEST(GrayImage, OtherEncodingsAndShortDataAreRefusedWithAReason) {
  for (const char* encoding : {"32FC1", "16SC1", "yuv422", "mono32", ""}) {
    SCOPED_TRACE(encoding);
    EXPECT_FALSE(isTrackableEncoding(encoding));
    cv::Mat gray;
    std::string why;
    EXPECT_FALSE(toGrayImage(uniformImage(encoding, {1, 2}), &gray, &why));
    EXPECT_NE(why.find("expected mono8"), std::string::npos) << why;
  }
  auto shorter = boost::make_shared<sensor_msgs::Image>(*uniformImage("bgr8", {1, 2, 3}));
  shorter->data.resize(shorter->data.size() - 1);
  cv::Mat gray;
  std::string why;
  EXPECT_FALSE(toGrayImage(shorter, &gray, &why));
  EXPECT_NE(why.find("shorter"), std::string::npos) << why;
  auto narrow = boost::make_shared<sensor_msgs::Image>(*uniformImage("rgba8", {1, 2, 3, 4}));
  narrow->step = 12;  // 4 pixels of 4 bytes need 16
  EXPECT_FALSE(toGrayImage(narrow, &gray, &why));
}

TEST(GrayImage, ACompressedPngIsDecodedLosslesslyAndGarbageIsRefused) {
  cv::Mat gray(37, 53, CV_8UC1), colour(37, 53, CV_8UC3);
  cv::randu(gray, 0, 256);
  cv::randu(colour, 0, 256);
  for (const cv::Mat& original : {gray, colour}) {
    sensor_msgs::CompressedImage msg;
    msg.header.stamp = ros::Time(12.5);
    msg.header.frame_id = "camera_left";
    msg.format = "png";
    ASSERT_TRUE(cv::imencode(".png", original, msg.data));
    std::string why;
    const sensor_msgs::ImagePtr image = decompressedImage(msg, &why);
    ASSERT_TRUE(image) << why;
    EXPECT_EQ(image->header.stamp, msg.header.stamp);
    EXPECT_EQ(image->header.frame_id, "camera_left");
    EXPECT_EQ(image->encoding, original.channels() == 1 ? "mono8" : "bgr8");
    ASSERT_EQ(image->width, 53u);
    ASSERT_EQ(image->height, 37u);
    const cv::Mat back(37, 53, original.type(), image->data.data(), image->step);
    EXPECT_EQ(cv::norm(back, original, cv::NORM_INF), 0.0);
  }
  sensor_msgs::CompressedImage garbage;
  garbage.format = "jpeg";
  garbage.data = {1, 2, 3, 4, 5};
  std::string why;
  EXPECT_FALSE(decompressedImage(garbage, &why));
  EXPECT_NE(why.find("cannot be decoded"), std::string::npos) << why;
}

TEST(GrayImage, PairCalibrationTakesTheEstimatorsRuleAndTheImageSize) {
  StereoCalibration rig;
  rig.fx = rig.fy = 700.0;
  rig.cx = 600.0;
  rig.cy = 180.0;
  rig.baseline = 0.54;
  rig.image_width = 1200;
  rig.image_height = 360;
  sensor_msgs::CameraInfo left_info, right_info;
  ros_conversions::cameraInfoFromCalibration(rig, &left_info, &right_info);
  sensor_msgs::Image left;
  left.width = 1200;
  left.height = 360;
  StereoCalibration stereo;
  std::string why;
  ASSERT_EQ(pairCalibration(left_info, right_info, left, &stereo, &why), PairCalibration::kOk);
  EXPECT_DOUBLE_EQ(stereo.cx, 600.0);
  EXPECT_NEAR(stereo.baseline, 0.54, 1e-12);
  // Another size than the camera_info's: refused, *stereo untouched.
  StereoCalibration untouched;
  left.width = 640;
  EXPECT_EQ(pairCalibration(left_info, right_info, left, &untouched, &why),
            PairCalibration::kSizeMismatch);
  EXPECT_EQ(untouched.fx, 0.0);
  EXPECT_NE(why.find("size"), std::string::npos) << why;
  // Principal points half a pixel apart: not a rectified pair.
  left.width = 1200;
  right_info.P[2] += 0.5;
  EXPECT_EQ(pairCalibration(left_info, right_info, left, &untouched, &why),
            PairCalibration::kCameraInfoRefused);
  EXPECT_EQ(untouched.fx, 0.0);
  EXPECT_EQ(why.rfind("camera_info refused: ", 0), 0u) << why;
}

// A 4 x 3 16-bit image of `encoding` (little-endian) whose every pixel holds `pixel`.
sensor_msgs::ImageConstPtr uniformImage16(const std::string& encoding,
                                          const std::vector<uint16_t>& pixel) {
  std::vector<uint8_t> bytes;
  for (const uint16_t value : pixel) {
    bytes.push_back(static_cast<uint8_t>(value & 0xff));
    bytes.push_back(static_cast<uint8_t>(value >> 8));
  }
  auto msg = boost::make_shared<sensor_msgs::Image>(*uniformImage(encoding, bytes));
  msg->is_bigendian = 0;
  return msg;
}

// One pair through toGrayPair with `scale`: both gray levels of pixel (2, 3), or -1 when refused.
std::pair<int, int> grayPair(DeepImageScale* scale, const sensor_msgs::ImageConstPtr& left,
                             const sensor_msgs::ImageConstPtr& right) {
  cv::Mat left_gray, right_gray;
  std::string why;
  if (!toGrayPair(left, right, scale, &left_gray, &right_gray, &why)) return {-1, -1};
  EXPECT_EQ(left_gray.type(), CV_8UC1);
  EXPECT_EQ(right_gray.type(), CV_8UC1);
  return {left_gray.at<uint8_t>(2, 3), right_gray.at<uint8_t>(2, 3)};
}

TEST(GrayImage, SixteenBitPairsAreScaledToEightBits) {
  // mono16 and 16UC1, little-endian: 12 significant bits read from the pair, / 16.
  DeepImageScale scale;
  EXPECT_EQ(grayPair(&scale, uniformImage16("mono16", {4095}), uniformImage16("16UC1", {2064})),
            std::make_pair(255, 129));
  EXPECT_EQ(scale.bits(), 12);
  // 8-bit pairs still share the message's data.
  DeepImageScale eight;
  const sensor_msgs::ImageConstPtr left = uniformImage("mono8", {77});
  cv::Mat left_gray, right_gray;
  std::string why;
  ASSERT_TRUE(toGrayPair(left, uniformImage("mono8", {9}), &eight, &left_gray, &right_gray, &why));
  EXPECT_EQ(left_gray.data, left->data.data());
  EXPECT_EQ(eight.bits(), 0);
}

TEST(GrayImage, BigEndianSixteenBitImagesGiveTheirValues) {
  // 4095 stored most significant byte first (cv_bridge alone returns such an image as 8UC2).
  auto left = boost::make_shared<sensor_msgs::Image>(*uniformImage("mono16", {0x0f, 0xff}));
  left->is_bigendian = 1;
  cv::Mat gray;
  std::string why;
  ASSERT_TRUE(toGrayImage(left, &gray, &why)) << why;
  EXPECT_EQ(gray.type(), CV_16UC1);
  DeepImageScale scale;
  EXPECT_EQ(grayPair(&scale, left, left), std::make_pair(255, 255));
  EXPECT_EQ(scale.bits(), 12);
  // Colour: pure blue, 4095 in the first channel, then 0 and 0 (12 bits).
  auto blue = boost::make_shared<sensor_msgs::Image>(
      *uniformImage("bgr16", {0x0f, 0xff, 0x00, 0x00, 0x00, 0x00}));
  blue->is_bigendian = 1;
  DeepImageScale twelve(12);
  EXPECT_EQ(grayPair(&twelve, blue, blue), std::make_pair(29, 29));
}

TEST(GrayImage, ColourAndBayerImagesAtSixteenBitsGiveTheirGrayLevel) {
  // Pure blue: 0.114 of full scale, as at 8 bits (29 of 255); a uniform Bayer mosaic: its value.
  DeepImageScale scale(16);
  EXPECT_EQ(grayPair(&scale, uniformImage16("bgr16", {65535, 0, 0}),
                     uniformImage16("rgba16", {0, 0, 65535, 9})),
            std::make_pair(29, 29));
  DeepImageScale bayer;
  EXPECT_EQ(grayPair(&bayer, uniformImage16("bayer_rggb16", {4000}),
                     uniformImage16("bayer_grbg16", {2000})),
            std::make_pair(250, 125));
  EXPECT_EQ(bayer.bits(), 12);
  // The message's data stays as it came.
  const sensor_msgs::ImageConstPtr left = uniformImage16("mono16", {4000});
  const std::vector<uint8_t> before = left->data;
  grayPair(&bayer, left, left);
  EXPECT_EQ(left->data, before);
}

}  // namespace
}  // namespace ekf_vislam
