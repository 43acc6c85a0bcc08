#include "ekf_vislam/tracker/debug_drawing.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(DebugDrawing, LeftAboveRightAndMaskedPixelsDimmed) {
  const cv::Mat left(60, 80, CV_8UC1, cv::Scalar(210)), right(60, 80, CV_8UC1, cv::Scalar(90));
  StereoFrame frame;
  StereoMasks masks;
  masks.left = cv::Mat(60, 80, CV_8UC1, cv::Scalar(255));
  masks.left(cv::Rect(0, 40, 80, 20)).setTo(0);  // the bottom rows of the left image
  const cv::Mat canvas = drawStereoTracks(left, right, frame, masks);
  ASSERT_EQ(canvas.size(), cv::Size(80, 120));
  ASSERT_EQ(canvas.type(), CV_8UC3);
  EXPECT_EQ(canvas.at<cv::Vec3b>(30, 70), cv::Vec3b(210, 210, 210));  // left, usable
  EXPECT_EQ(canvas.at<cv::Vec3b>(45, 70), cv::Vec3b(70, 70, 70));     // left, masked
  EXPECT_EQ(canvas.at<cv::Vec3b>(90, 70), cv::Vec3b(90, 90, 90));     // right, no mask
  // A mask of another size is not drawn.
  masks.left = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(drawStereoTracks(left, right, frame, masks).at<cv::Vec3b>(45, 70),
            cv::Vec3b(210, 210, 210));
}

// The right match is drawn where the image has it, not moved by the rig's disparity correction.
TEST(DebugDrawing, TheRightMatchIsDrawnWhereTheImageHasIt) {
  const cv::Mat left(60, 80, CV_8UC1, cv::Scalar(90)), right(60, 80, CV_8UC1, cv::Scalar(90));
  StereoFrame frame;
  frame.stats.disparity_offset_corrected_px = -10.f;
  TrackedFeature feature;
  feature.left = cv::Point2f(40.f, 30.f);
  feature.right = cv::Point2f(15.f, 30.f);  // published: measured at u = 25, moved by -10 px
  frame.features.push_back(feature);
  const cv::Mat canvas = drawStereoTracks(left, right, frame);
  const cv::Vec3b gray(90, 90, 90);
  EXPECT_NE(canvas.at<cv::Vec3b>(90, 22), gray);  // the circle about the measured match
  EXPECT_EQ(canvas.at<cv::Vec3b>(90, 12), gray);  // none about the published column
}

}  // namespace
}  // namespace ekf_vislam
