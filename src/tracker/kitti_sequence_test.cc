#include "ekf_vislam/tracker/kitti_sequence.h"

#include "ekf_vislam/tracker/frame_rate_limit.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace ekf_vislam
