#include "ekf_vislam/tracker/kitti_sequence.h"

#include "ekf_vislam/tracker/frame_rate_limit.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace ekf_vislam {
namespace {

KittiSequence sequenceOf(size_t n, bool with_poses) {
  KittiSequence sequence;
  for (size_t k = 0; k < n; ++k) {
    sequence.left_images.push_back("left/" + std::to_string(k) + ".png");
    sequence.right_images.push_back("right/" + std::to_string(k) + ".png");
    sequence.times.push_back(0.1 * k);
    if (!with_poses) continue;
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    pose(2, 3) = static_cast<double>(k);
    sequence.world_T_cam.push_back(pose);
  }
  return sequence;
}

TEST(KittiSequence, KeepsTheFramesDueUnderARateLimitWithTheirPoses) {
  KittiSequence sequence = sequenceOf(10, true);
  sequence.dropFirstFrames(1);
  sequence.keepFrames(framesDueForTracking(sequence.times, 5.0));
  ASSERT_EQ(sequence.size(), 5u);
  ASSERT_EQ(sequence.world_T_cam.size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    const size_t original = 1 + 2 * k;
    EXPECT_DOUBLE_EQ(sequence.times[k], 0.1 * original);
    EXPECT_EQ(sequence.left_images[k], "left/" + std::to_string(original) + ".png");
    EXPECT_EQ(sequence.right_images[k], "right/" + std::to_string(original) + ".png");
    EXPECT_DOUBLE_EQ(sequence.world_T_cam[k](2, 3), static_cast<double>(original));
  }
}

TEST(KittiSequence, KeepsFramesWithoutPoses) {
  KittiSequence sequence = sequenceOf(4, false);
  sequence.keepFrames({0, 3});
  ASSERT_EQ(sequence.size(), 2u);
  EXPECT_TRUE(sequence.world_T_cam.empty());
  EXPECT_EQ(sequence.left_images[1], "left/3.png");
}

// KITTI odometry 00's calib.txt: P0-P3 (P2, P3 the colour cameras) and Tr.
const char* kKitti00Calib =
    "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 "
    "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
    "P1: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 -3.861448000000e+02 "
    "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
    "P2: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 4.538225000000e+01 "
    "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 -1.130887000000e-01 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 3.779761000000e-03\n"
    "P3: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 -3.372877000000e+02 "
    "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 2.369057000000e+00 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 4.915215000000e-03\n"
    "Tr: 4.276802385584e-04 -9.999672484946e-01 -8.084491683471e-03 -1.198459927713e-02 "
    "-7.210626507497e-03 8.081198471645e-03 -9.999413164504e-01 -5.403984729748e-02 "
    "9.999738645903e-01 4.859485810390e-04 -7.206933692422e-03 -2.921968648686e-01\n";

// A KITTI-layout folder of two frames (empty image files: only their names are read).
std::string kittiFolder(const std::string& name) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::temp_directory_path() / ("ekf_vislam_kitti_" + name);
  fs::remove_all(folder);
  for (const char* side : {"left", "right"}) {
    fs::create_directories(folder / side);
    for (const char* image : {"000000.png", "000001.png"}) std::ofstream(folder / side / image);
  }
  std::ofstream(folder / "calib.txt") << kKitti00Calib;
  std::ofstream(folder / "times.txt") << "0.0\n0.1\n";
  std::ofstream(folder / "poses.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1.5\n";
  return folder.string();
}

TEST(KittiSequence, ReadsTheColourCamerasAndMovesThePosesToTheLeftOne) {
  const std::string folder = kittiFolder("colour");
  KittiSequence gray, colour;
  std::string error;
  ASSERT_TRUE(loadKittiSequence(folder + "/left", folder + "/right", folder + "/calib.txt",
                                folder + "/times.txt", folder + "/poses.txt", &gray, &error))
      << error;
  EXPECT_DOUBLE_EQ(gray.calibration.fx, 718.856);
  EXPECT_NEAR(gray.calibration.baseline, 386.1448 / 718.856, 1e-12);
  EXPECT_TRUE(gray.world_T_cam[0].isIdentity(0.0));  // camera 0's own poses
  EXPECT_EQ(gray.world_T_cam[1](2, 3), 1.5);
  ASSERT_TRUE(loadKittiSequence(folder + "/left", folder + "/right", folder + "/calib.txt",
                                folder + "/times.txt", folder + "/poses.txt", &colour, &error,
                                KittiCameras{2, 3}))
      << error;
  EXPECT_DOUBLE_EQ(colour.calibration.cx, 607.1928);
  EXPECT_NEAR(colour.calibration.baseline, (45.38225 + 337.2877) / 718.856, 1e-12);  // 0.5323 m
  // Camera 2 sits about 6 cm left of camera 0 (KITTI's rig): its poses are camera 0's moved so.
  const Eigen::Vector3d p_cam2_in_cam0 = colour.world_T_cam[0].topRightCorner<3, 1>();
  EXPECT_NEAR(p_cam2_in_cam0.x(), -0.05994, 1e-5);
  EXPECT_NEAR(p_cam2_in_cam0.y(), 0.00113, 1e-5);
  EXPECT_NEAR(p_cam2_in_cam0.z(), -0.00378, 1e-5);
  EXPECT_NEAR(colour.world_T_cam[1](2, 3), 1.5 - 0.00378, 1e-5);
  std::filesystem::remove_all(folder);
}

TEST(KittiSequence, FindsTheImagesOfEitherLayout) {
  namespace fs = std::filesystem;
  const fs::path own = kittiFolder("own_layout");
  fs::rename(own / "left", own / "image_left");
  fs::rename(own / "right", own / "image_right");
  KittiFolder parts = kittiFolderParts(own.string());
  EXPECT_EQ(parts.left, (own / "image_left").string());
  EXPECT_EQ(parts.right, (own / "image_right").string());
  EXPECT_EQ(parts.calib, (own / "calib.txt").string());
  EXPECT_EQ(parts.times, (own / "times.txt").string());
  EXPECT_EQ(parts.poses, (own / "poses.txt").string());
  // The colour cameras are KITTI's image_2 and image_3, whatever else the folder holds.
  EXPECT_EQ(kittiFolderParts(own.string(), {2, 3}).left, (own / "image_2").string());
  // One folder of the own layout missing: it is the one named, not KITTI's.
  fs::remove_all(own / "image_right");
  EXPECT_EQ(kittiFolderParts(own.string()).right, (own / "image_right").string());

  const fs::path kitti = kittiFolder("kitti_layout");
  fs::rename(kitti / "left", kitti / "image_0");
  fs::rename(kitti / "right", kitti / "image_1");
  fs::remove(kitti / "poses.txt");
  parts = kittiFolderParts(kitti.string());
  EXPECT_EQ(parts.left, (kitti / "image_0").string());
  EXPECT_EQ(parts.right, (kitti / "image_1").string());
  EXPECT_TRUE(parts.poses.empty());
  KittiSequence sequence;
  std::string error;
  EXPECT_TRUE(loadKittiSequence(parts.left, parts.right, parts.calib, parts.times, parts.poses,
                                &sequence, &error))
      << error;
  EXPECT_EQ(sequence.size(), 2u);
  fs::remove_all(own);
  fs::remove_all(kitti);
}

TEST(KittiSequence, NamesTheMissingProjection) {
  const std::string folder = kittiFolder("missing");
  StereoCalibration calibration;
  std::string error;
  EXPECT_FALSE(readKittiCalibration(folder + "/calib.txt", &calibration, &error, {2, 5}));
  EXPECT_NE(error.find("P2 and P5"), std::string::npos) << error;
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace ekf_vislam
