#include "ekf_vislam/tracker/rectified_stereo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace ekf_vislam {
namespace {

// KITTI odometry 06 (P0, P1).
StereoCalibration kittiCalibration() {
  return rectifiedPair(707.0912, 707.0912, 601.8873, 183.1104, 379.8145 / 707.0912);
}

// Round numbers whose projections are exact in float.
StereoCalibration roundCalibration() { return rectifiedPair(500, 400, 320, 240, 0.5); }

// A point of the left camera frame seen from the right camera (baseline metres along +x).
Eigen::Vector3d inRightCamera(const StereoCalibration& c, const Eigen::Vector3d& p_cam) {
  return p_cam - Eigen::Vector3d(c.baseline, 0, 0);
}

TEST(RectifiedStereo, ProjectionOfTriangulatedPointGivesBothPixels) {
  for (const StereoCalibration& c : {kittiCalibration(), roundCalibration()}) {
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
  const StereoCalibration c = roundCalibration();
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
  const StereoCalibration k = kittiCalibration();
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
  const StereoCalibration c = kittiCalibration();
  const cv::Point2f left(400.5f, 120.25f);
  for (const double disparity :
       {0.0, -0.0, -1e-9, -0.5, -300.0, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_FALSE(triangulate(c, left, disparity).has_value()) << disparity;
  }
  EXPECT_TRUE(triangulate(c, left, 1e-6).has_value());
}

TEST(RectifiedStereo, DisparityAtDepth) {
  const StereoCalibration c = kittiCalibration();
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
  const StereoCalibration c = roundCalibration();
  const Eigen::Vector3d ray = normalized(c, cv::Point2f(370, 200));
  EXPECT_EQ(ray, Eigen::Vector3d(0.1, -0.1, 1.0));
  const StereoCalibration k = kittiCalibration();
  const cv::Point2f pixel(1000.125f, 50.75f);
  for (const double z : {1.0, 3.5, 60.0}) {
    const Eigen::Vector2d back = project(k, z * normalized(k, pixel));
    EXPECT_NEAR(back.x(), pixel.x, 1e-9);
    EXPECT_NEAR(back.y(), pixel.y, 1e-9);
  }
}

TEST(RectifiedStereo, RectifiedPairIsAValidCalibrationWithoutExtrinsic) {
  const StereoCalibration pair = rectifiedPair(718.856, 718.5, 607.1928, 185.2157, 0.5372);
  EXPECT_EQ(pair.validate(), "");
  EXPECT_EQ(pair.fx, 718.856);
  EXPECT_EQ(pair.fy, 718.5);
  EXPECT_EQ(pair.cx, 607.1928);
  EXPECT_EQ(pair.cy, 185.2157);
  EXPECT_EQ(pair.baseline, 0.5372);
  EXPECT_TRUE(pair.cam_T_imu.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_FALSE(rectifiedPair(718.856, 718.5, 607.1928, 185.2157, 0.0).validate().empty());
}

TEST(RectifiedStereo, SamePairComparesEveryIntrinsicAndTheBaseline) {
  const StereoCalibration k = kittiCalibration();
  StereoCalibration other = k;
  other.cam_T_imu.translation().x() = 1.0;  // not the tracker's concern
  other.image_width = 1241;
  EXPECT_TRUE(sameRectifiedPair(k, other));
  for (double StereoCalibration::*field :
       {&StereoCalibration::fx, &StereoCalibration::fy, &StereoCalibration::cx,
        &StereoCalibration::cy, &StereoCalibration::baseline}) {
    StereoCalibration changed = k;
    changed.*field += 1e-6;
    EXPECT_FALSE(sameRectifiedPair(k, changed));
  }
}

}  // namespace
}  // namespace ekf_vislam
