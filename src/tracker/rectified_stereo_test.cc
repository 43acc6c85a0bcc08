#include "ekf_vislam/tracker/rectified_stereo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace ekf_vislam {
namespace {

// KITTI odometry 06 (P0, P1).
RectifiedStereo kittiCalibration() {
  RectifiedStereo c;
  c.fx = c.fy = 707.0912;
  c.cx = 601.8873;
  c.cy = 183.1104;
  c.baseline = 379.8145 / 707.0912;
  return c;
}

// Round numbers whose projections are exact in float.
RectifiedStereo roundCalibration() {
  RectifiedStereo c;
  c.fx = 500;
  c.fy = 400;
  c.cx = 320;
  c.cy = 240;
  c.baseline = 0.5;
  return c;
}

// A point of the left camera frame seen from the right camera (baseline metres along +x).
Eigen::Vector3d inRightCamera(const RectifiedStereo& c, const Eigen::Vector3d& p_cam) {
  return p_cam - Eigen::Vector3d(c.baseline, 0, 0);
}

TEST(RectifiedStereo, ProjectionOfTriangulatedPointGivesBothPixels) {
  for (const RectifiedStereo& c : {kittiCalibration(), roundCalibration()}) {
    for (const cv::Point2f left : {cv::Point2f(10.25f, 5.5f), cv::Point2f(601.9f, 183.1f),
                                   cv::Point2f(1200.75f, 360.125f), cv::Point2f(333.3f, 17.7f)}) {
      for (const double disparity : {0.01, 0.5, 3.25, 40.0, 250.0}) {
        const std::optional<Eigen::Vector3d> p_cam = triangulate(c, left, disparity);
        ASSERT_TRUE(p_cam.has_value());
        EXPECT_GT(p_cam->z(), 0);
        const Eigen::Vector2d in_left = project(c, *p_cam);
        EXPECT_NEAR(in_left.x(), left.x, 1e-9) << c.fy << " " << disparity;
        EXPECT_NEAR(in_left.y(), left.y, 1e-9) << c.fy << " " << disparity;
        const Eigen::Vector2d in_right = project(c, inRightCamera(c, *p_cam));
        EXPECT_NEAR(in_right.x(), left.x - disparity, 1e-9) << c.fy << " " << disparity;
        EXPECT_NEAR(in_right.y(), left.y, 1e-9) << c.fy << " " << disparity;
      }
    }
  }
}

TEST(RectifiedStereo, TriangulatingTheProjectionsRecoversThePoint) {
  // Exact case: the pixels and the disparity of these points are exact in float.
  const RectifiedStereo c = roundCalibration();
  for (const Eigen::Vector3d& p_cam : {Eigen::Vector3d(1, -0.5, 10), Eigen::Vector3d(-2, 3, 4),
                                       Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(25, -12.5, 125)}) {
    const Eigen::Vector2d left = project(c, p_cam);
    const Eigen::Vector2d right = project(c, inRightCamera(c, p_cam));
    const cv::Point2f left_px(static_cast<float>(left.x()), static_cast<float>(left.y()));
    const cv::Point2f right_px(static_cast<float>(right.x()), static_cast<float>(right.y()));
    ASSERT_EQ(left_px.x, left.x());
    ASSERT_EQ(right_px.x, right.x());
    EXPECT_EQ(right.y(), left.y());
    const std::optional<Eigen::Vector3d> p = triangulate(c, left_px, left_px.x - right_px.x);
    ASSERT_TRUE(p.has_value());
    EXPECT_LT((*p - p_cam).norm(), 1e-12) << p_cam.transpose() << " -> " << p->transpose();
  }
  // General case, float pixels: within what a float pixel resolves.
  const RectifiedStereo k = kittiCalibration();
  for (const Eigen::Vector3d& p_cam :
       {Eigen::Vector3d(1.3, -0.7, 8.9), Eigen::Vector3d(-4.1, 1.9, 23.7),
        Eigen::Vector3d(0.05, 0.02, 2.2)}) {
    const Eigen::Vector2d left = project(k, p_cam);
    const Eigen::Vector2d right = project(k, inRightCamera(k, p_cam));
    const cv::Point2f left_px(static_cast<float>(left.x()), static_cast<float>(left.y()));
    const double disparity = left.x() - right.x();
    EXPECT_NEAR(disparity, disparityAtDepth(k, p_cam.z()), 1e-9);
    const std::optional<Eigen::Vector3d> p = triangulate(k, left_px, disparity);
    ASSERT_TRUE(p.has_value());
    EXPECT_NEAR(p->z(), p_cam.z(), 1e-12 * p_cam.z());
    // 1e-4 px of float rounding at this depth.
    const double tolerance = 1e-4 * p_cam.z() / k.fx;
    EXPECT_NEAR(p->x(), p_cam.x(), tolerance);
    EXPECT_NEAR(p->y(), p_cam.y(), tolerance);
  }
}

TEST(RectifiedStereo, NonPositiveDisparityGivesNoPoint) {
  const RectifiedStereo c = kittiCalibration();
  const cv::Point2f left(400.5f, 120.25f);
  for (const double disparity :
       {0.0, -0.0, -1e-9, -0.5, -300.0, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_FALSE(triangulate(c, left, disparity).has_value()) << disparity;
  }
  EXPECT_TRUE(triangulate(c, left, 1e-6).has_value());
}

TEST(RectifiedStereo, DisparityAtDepth) {
  const RectifiedStereo c = kittiCalibration();
  for (const double z : {0.5, 1.0, 7.3, 40.0, 1000.0}) {
    EXPECT_EQ(disparityAtDepth(c, z), c.fx * c.baseline / z) << z;
    const std::optional<Eigen::Vector3d> p =
        triangulate(c, cv::Point2f(700, 200), disparityAtDepth(c, z));
    ASSERT_TRUE(p.has_value());
    EXPECT_NEAR(p->z(), z, 1e-12 * z);
  }
  EXPECT_NEAR(disparityAtDepth(roundCalibration(), 10.0), 25.0, 1e-12);
}

TEST(RectifiedStereo, NormalizedIsThePixelsRayAtUnitDepth) {
  const RectifiedStereo c = roundCalibration();
  const Eigen::Vector3d ray = normalized(c, cv::Point2f(370, 200));
  EXPECT_EQ(ray, Eigen::Vector3d(0.1, -0.1, 1.0));
  const RectifiedStereo k = kittiCalibration();
  const cv::Point2f pixel(1000.125f, 50.75f);
  for (const double z : {1.0, 3.5, 60.0}) {
    const Eigen::Vector2d back = project(k, z * normalized(k, pixel));
    EXPECT_NEAR(back.x(), pixel.x, 1e-9);
    EXPECT_NEAR(back.y(), pixel.y, 1e-9);
  }
}

TEST(RectifiedStereo, TakesTheEstimatorsCalibration) {
  StereoCalibration calibration;
  calibration.fx = 718.856;
  calibration.fy = 718.5;
  calibration.cx = 607.1928;
  calibration.cy = 185.2157;
  calibration.baseline = 0.5372;
  const RectifiedStereo stereo = rectifiedStereoOf(calibration);
  EXPECT_EQ(stereo.fx, 718.856);
  EXPECT_EQ(stereo.fy, 718.5);
  EXPECT_EQ(stereo.cx, 607.1928);
  EXPECT_EQ(stereo.cy, 185.2157);
  EXPECT_EQ(stereo.baseline, 0.5372);
}

}  // namespace
}  // namespace ekf_vislam
