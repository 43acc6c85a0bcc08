#include "ekf_vislam/tracker/twist_motion_prior.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/tracker/pose_twist.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace ekf_vislam {
namespace {

/// A curving, climbing drive of world_T_imu poses at 10 Hz, and its exact twist samples.
struct Drive {
  std::vector<double> times;
  std::vector<Eigen::Matrix4d> world_T_imu;
  std::deque<StampedTwist> twists;
};

Drive curvingDrive() {
  Drive drive;
  for (int k = 0; k < 20; ++k) {
    const double t = 0.1 * k;
    Vector6d xi;
    xi << 8.0 * t, 0.3 * std::sin(t), 0.1 * t, 0.02 * t, 0.05 * std::sin(2 * t), 0.4 * t * t;
    drive.times.push_back(t);
    drive.world_T_imu.push_back(se3::exp(xi));
  }
  std::vector<Eigen::Vector3d> v, w;
  TwistNoise exact;
  exact.linear_sigma = exact.angular_sigma = exact.gyro_offset = 0.0;
  twistFromPoses(drive.world_T_imu, drive.times, exact, &v, &w);
  for (size_t k = 0; k < v.size(); ++k) drive.twists.push_back({drive.times[k], v[k], w[k]});
  return drive;
}

TEST(TwistMotionPrior, ExactTwistGivesTheCameraMotion) {
  const Drive drive = curvingDrive();
  const Eigen::Matrix4d cam_T_imu = forwardLeftUpCamTImu();
  for (size_t k = 1; k < drive.times.size(); ++k) {
    const auto prior =
        motionPriorFromTwists(drive.twists, cam_T_imu, drive.times[k - 1], drive.times[k]);
    ASSERT_TRUE(prior.has_value());
    // p_cur = cur_T_prev p_prev with cur_T_prev = cam_T_imu imu_k^-1 imu_(k-1) imu_T_cam.
    const Eigen::Matrix4d expected = cam_T_imu * se3::inverse(drive.world_T_imu[k]) *
                                     drive.world_T_imu[k - 1] * se3::inverse(cam_T_imu);
    EXPECT_TRUE(prior->has_translation);
    EXPECT_LT((prior->cur_R_prev - expected.block<3, 3>(0, 0)).norm(), 1e-9) << k;
    EXPECT_LT((prior->cur_t_prev - expected.block<3, 1>(0, 3)).norm(), 1e-9) << k;
  }
}

TEST(TwistMotionPrior, SpansSeveralSamplesAndPartsOfThem) {
  const Drive drive = curvingDrive();
  const Eigen::Matrix4d cam_T_imu = forwardLeftUpCamTImu();
  // Over three frame intervals: the product of the three one-interval motions.
  const auto whole = motionPriorFromTwists(drive.twists, cam_T_imu, 0.3, 0.6);
  ASSERT_TRUE(whole.has_value());
  const Eigen::Matrix4d expected = cam_T_imu * se3::inverse(drive.world_T_imu[6]) *
                                   drive.world_T_imu[3] * se3::inverse(cam_T_imu);
  EXPECT_LT((whole->cur_t_prev - expected.block<3, 1>(0, 3)).norm(), 1e-9);
  // Half of an interval: half of that interval's (constant) twist.
  const auto half = motionPriorFromTwists(drive.twists, cam_T_imu, 0.5, 0.55);
  ASSERT_TRUE(half.has_value());
  Vector6d xi;
  xi << drive.twists[6].v, drive.twists[6].w;
  const Eigen::Matrix4d half_expected =
      se3::inverse(cam_T_imu * se3::exp(0.05 * xi) * se3::inverse(cam_T_imu));
  EXPECT_LT((half->cur_t_prev - half_expected.block<3, 1>(0, 3)).norm(), 1e-12);
}

TEST(TwistMotionPrior, NoPriorWithoutTwistsToTheImage) {
  const Drive drive = curvingDrive();
  const Eigen::Matrix4d cam_T_imu = forwardLeftUpCamTImu();
  EXPECT_FALSE(motionPriorFromTwists({}, cam_T_imu, 0.0, 0.1).has_value());
  EXPECT_FALSE(motionPriorFromTwists(drive.twists, cam_T_imu, 0.5, 0.5).has_value());
  EXPECT_FALSE(motionPriorFromTwists(drive.twists, cam_T_imu, 1.85, 1.95).has_value());
}

TEST(TwistMotionPrior, KeptTwistsStillGiveThePriorFromTheLastPair) {
  // 10 s of twists at 10 Hz, turning and speeding up.
  std::deque<StampedTwist> all;
  for (int k = 1; k <= 100; ++k) {
    const double t = 0.1 * k;
    all.push_back({t, Eigen::Vector3d(5.0 + t, 0.1, 0.0), Eigen::Vector3d(0.0, 0.01, 0.1 * t)});
  }
  const Eigen::Matrix4d cam_T_imu = forwardLeftUpCamTImu();
  for (const double last_pair : {2.05, 7.05}) {
    std::deque<StampedTwist> kept;
    for (const StampedTwist& twist : all) EXPECT_TRUE(keepTwist(twist, last_pair, &kept));
    EXPECT_FALSE(keepTwist(all[50], last_pair, &kept));  // not newer: not kept
    // Gone: what lies before both the last pair and the last 5 s (to 5.0 s), but for the twist
    // whose interval holds that time.
    const double keep_from = std::min(last_pair, 5.0);
    ASSERT_GE(kept.size(), 2u);
    EXPECT_LT(kept.front().stamp, keep_from);
    EXPECT_GE(kept[1].stamp, keep_from);
    EXPECT_LT(kept.size(), all.size());
    const auto from_kept = motionPriorFromTwists(kept, cam_T_imu, last_pair, 9.95);
    const auto from_all = motionPriorFromTwists(all, cam_T_imu, last_pair, 9.95);
    ASSERT_TRUE(from_kept.has_value() && from_all.has_value());
    EXPECT_EQ(from_kept->cur_t_prev, from_all->cur_t_prev);
    EXPECT_EQ(from_kept->cur_R_prev, from_all->cur_R_prev);
  }
}

}  // namespace
}  // namespace ekf_vislam
