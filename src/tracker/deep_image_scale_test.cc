// Unit tests of DeepImageScale: 16-bit images to the tracker's 8 bits.
#include "ekf_vislam/tracker/deep_image_scale.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <utility>

namespace ekf_vislam {
namespace {

// One pair of uniform 4 x 3 images (16-bit where the value is given as such) through `scale`:
// both gray levels.
std::pair<int, int> scaled(DeepImageScale* scale, const cv::Mat& left_in, const cv::Mat& right_in) {
  cv::Mat left = left_in, right = right_in;
  scale->scalePair(&left, &right);
  EXPECT_EQ(left.type(), CV_8UC1);
  EXPECT_EQ(right.type(), CV_8UC1);
  return {left.at<uint8_t>(2, 3), right.at<uint8_t>(2, 3)};
}

cv::Mat deep(int value) { return cv::Mat(3, 4, CV_16UC1, cv::Scalar(value)); }

TEST(DeepImageScale, TwelveBitValuesFillTheEightBitRange) {
  // Stored from bit 0 up: a pair whose brightest value is 4095 has 12 significant bits, and both
  // images are divided by 16 (rounded, saturated).
  DeepImageScale scale;
  EXPECT_EQ(scaled(&scale, deep(4095), deep(2064)), std::make_pair(255, 129));
  EXPECT_EQ(scale.bits(), 12);
  EXPECT_TRUE(scale.changed());
  EXPECT_EQ(scale.describe(),
            "16-bit images: value / 16 tracked (12 significant bits, read from the images)");
  // Stored from bit 15 down (or a 16-bit camera's): the top 8 bits.
  DeepImageScale high;
  EXPECT_EQ(scaled(&high, deep(65520), deep(32768)), std::make_pair(255, 128));
  EXPECT_EQ(high.bits(), 16);
}

TEST(DeepImageScale, TheBitsReadFromTheImagesOnlyGrow) {
  DeepImageScale scale;
  EXPECT_EQ(scaled(&scale, deep(1000), deep(500)), std::make_pair(250, 125));  // 10 bits: / 4
  EXPECT_EQ(scale.bits(), 10);
  EXPECT_EQ(scaled(&scale, deep(800), deep(4000)), std::make_pair(50, 250));  // 12 bits: / 16
  EXPECT_TRUE(scale.changed());
  EXPECT_EQ(scaled(&scale, deep(1008), deep(16)), std::make_pair(63, 1));  // still / 16
  EXPECT_FALSE(scale.changed());
  EXPECT_EQ(scale.bits(), 12);
  // A dark stream never goes below 8 bits: its values are taken as they are.
  DeepImageScale dark;
  EXPECT_EQ(scaled(&dark, deep(40), deep(7)), std::make_pair(40, 7));
  EXPECT_EQ(dark.bits(), 8);
}

TEST(DeepImageScale, ALightInViewDoesNotDarkenTheRest) {
  // A dark scene using 10 of a 12-bit camera's bits, 200 x 100 pixels (a pair counts 2 x 5000,
  // every other row and column); a light that saturates 2 of them (0.02 %) leaves it at / 4, one
  // over 20 (0.2 %) takes the scale to 12 bits.
  DeepImageScale scale;
  cv::Mat left(100, 200, CV_16UC1, cv::Scalar(1000)), right = left.clone();
  EXPECT_EQ(scaled(&scale, left, right), std::make_pair(250, 250));
  EXPECT_EQ(scale.bits(), 10);
  left(cv::Rect(0, 0, 4, 2)).setTo(4095);  // counted: row 0, columns 0 and 2
  EXPECT_EQ(scaled(&scale, left, right), std::make_pair(250, 250));
  EXPECT_EQ(scale.bits(), 10);
  EXPECT_FALSE(scale.changed());
  left(cv::Rect(0, 0, 40, 2)).setTo(4095);  // counted: row 0, columns 0, 2, ..., 38
  EXPECT_EQ(scaled(&scale, left, right), std::make_pair(62, 62));  // 62.5, rounded to even
  EXPECT_EQ(scale.bits(), 12);
}

TEST(DeepImageScale, FixedBitsSaturateAndEightBitImagesStayAsTheyAre) {
  DeepImageScale scale(12);
  EXPECT_EQ(scaled(&scale, deep(65535), deep(160)), std::make_pair(255, 10));
  EXPECT_EQ(scale.bits(), 12);
  EXPECT_EQ(scale.describe(),
            "16-bit images: value / 16 tracked (12 significant bits, ros/image_bits)");
  DeepImageScale eight;
  cv::Mat left(3, 4, CV_8UC1, cv::Scalar(77)), right(3, 4, CV_8UC1, cv::Scalar(9));
  const uint8_t* data = left.data;
  eight.scalePair(&left, &right);
  EXPECT_EQ(left.data, data);  // not copied
  EXPECT_EQ(eight.bits(), 0);
  EXPECT_FALSE(eight.changed());
  // The 16-bit data itself is not written.
  const cv::Mat original = deep(4000);
  cv::Mat image = original, other = deep(10);
  eight.scalePair(&image, &other);
  EXPECT_EQ(original.at<uint16_t>(2, 3), 4000);
}

}  // namespace
}  // namespace ekf_vislam
