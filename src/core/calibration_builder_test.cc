#include "ekf_vislam/core/calibration_builder.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

PinholeProjection leftProjection() { return {707.0, 706.0, 601.0, 183.0, 0.0, 1241, 376}; }

PinholeProjection rightProjection(double baseline) {
  PinholeProjection right = leftProjection();
  right.tx = -right.fx * baseline;
  return right;
}

Eigen::Isometry3d someImuTCam() {
  Eigen::Isometry3d imu_T_cam = Eigen::Isometry3d::Identity();
  imu_T_cam.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  imu_T_cam.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  return imu_T_cam;
}

TEST(CalibrationBuilder, ProjectionsAndTransformGiveTheCalibration) {
  CalibrationBuilder builder{CalibrationOverride()};
  EXPECT_TRUE(builder.needsProjections());
  EXPECT_TRUE(builder.needsImuTCam());
  std::string why;
  ASSERT_TRUE(builder.setProjections(leftProjection(), rightProjection(0.54), &why)) << why;
  StereoCalibration calibration;
  EXPECT_FALSE(builder.complete());
  EXPECT_FALSE(builder.build(&calibration, &why));
  EXPECT_NE(why.find("transform"), std::string::npos) << why;
  builder.setImuTCam(someImuTCam());
  EXPECT_TRUE(builder.complete());
  ASSERT_TRUE(builder.build(&calibration, &why)) << why;
  EXPECT_DOUBLE_EQ(calibration.fx, 707.0);
  EXPECT_DOUBLE_EQ(calibration.fy, 706.0);
  EXPECT_DOUBLE_EQ(calibration.cx, 601.0);
  EXPECT_DOUBLE_EQ(calibration.cy, 183.0);
  EXPECT_NEAR(calibration.baseline, 0.54, 1e-12);
  EXPECT_EQ(calibration.image_width, 1241);
  EXPECT_EQ(calibration.image_height, 376);
  EXPECT_TRUE((calibration.cam_T_imu * someImuTCam()).isApprox(Eigen::Isometry3d::Identity()));
}

TEST(CalibrationBuilder, SaysWhatIsMissingOrRefused) {
  CalibrationBuilder builder{CalibrationOverride()};
  builder.setImuTCam(someImuTCam());
  StereoCalibration calibration;
  std::string why;
  EXPECT_FALSE(builder.build(&calibration, &why));
  EXPECT_NE(why.find("no camera_info"), std::string::npos) << why;

  PinholeProjection unrectified = rightProjection(0.54);
  unrectified.cx += 3.0;
  EXPECT_FALSE(builder.setProjections(leftProjection(), unrectified, &why));
  EXPECT_NE(why.find("rectified"), std::string::npos) << why;
  EXPECT_FALSE(builder.build(&calibration, &why));
  EXPECT_NE(why.find("camera_info refused"), std::string::npos) << why;

  EXPECT_FALSE(builder.setProjections(leftProjection(), rightProjection(-0.54), &why));
  EXPECT_NE(why.find("baseline"), std::string::npos) << why;
  PinholeProjection no_focal = leftProjection();
  no_focal.fx = 0.0;
  EXPECT_FALSE(builder.setProjections(no_focal, rightProjection(0.54), &why));
  EXPECT_NE(why.find("focal"), std::string::npos) << why;
}

TEST(CalibrationBuilder, OverrideReplacesEachSourceItGives) {
  CalibrationOverride intrinsics_only;
  intrinsics_only.has_intrinsics = true;
  intrinsics_only.calibration.fx = intrinsics_only.calibration.fy = 500.0;
  intrinsics_only.calibration.cx = 320.0;
  intrinsics_only.calibration.cy = 240.0;
  intrinsics_only.calibration.baseline = 0.12;
  CalibrationBuilder builder(intrinsics_only);
  EXPECT_FALSE(builder.needsProjections());
  EXPECT_TRUE(builder.needsImuTCam());
  builder.setImuTCam(someImuTCam());
  StereoCalibration calibration;
  std::string why;
  ASSERT_TRUE(builder.build(&calibration, &why)) << why;
  EXPECT_DOUBLE_EQ(calibration.fx, 500.0);
  EXPECT_DOUBLE_EQ(calibration.baseline, 0.12);

  CalibrationOverride both = intrinsics_only;
  both.has_extrinsic = true;
  both.calibration.cam_T_imu = someImuTCam();
  CalibrationBuilder complete(both);
  EXPECT_FALSE(complete.needsImuTCam());
  ASSERT_TRUE(complete.build(&calibration, &why)) << why;
  EXPECT_TRUE(calibration.cam_T_imu.isApprox(someImuTCam()));

  CalibrationOverride invalid = both;
  invalid.calibration.baseline = -0.12;
  EXPECT_FALSE(CalibrationBuilder(invalid).build(&calibration, &why));
  EXPECT_NE(why.find("calibration refused"), std::string::npos) << why;
}

}  // namespace
}  // namespace ekf_vislam
