#include "ekf_vislam/core/landmark_manager.h"

#include "ekf_vislam/core/se3.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

#include <unordered_set>
#include <vector>

namespace ekf_vislam {
namespace {

// A SLAM state at a turned, moved pose with the KITTI-like camera, and exact stereo observations
// of world points from it.
class LandmarkManagerTest : public ::testing::Test {
 protected:
  LandmarkManagerTest() {
    options_.landmarks.max_active = 3;
    options_.landmarks.max_track_gap = 1;
    StatePrior prior;
    prior.position_sigma = 0.2;
    prior.rotation_sigma = 0.01;
    state_.reset(prior);
    world_T_imu_ = se3::exp((Vector6d() << 3.0, -1.0, 0.2, 0.01, -0.02, 0.4).finished());
    state_.imu_T_world = se3::inverse(world_T_imu_);
  }

  // The world point `ahead` m in front of the IMU, `left` m to its left.
  Eigen::Vector3d worldPoint(double ahead, double left) const {
    return (world_T_imu_ * Eigen::Vector4d(ahead, left, 0.5, 1.0)).head<3>();
  }

  StereoObservation observe(uint32_t id, const Eigen::Vector3d& p_world) const {
    Eigen::Vector4d z;
    EXPECT_TRUE(camera_.project(state_.imu_T_world, p_world, &z));
    return StereoObservation{id, z(0), z(1), z(2), z(3)};
  }

  bool initialize(const StereoObservation& f) {
    return landmarks_.initialize(f, 1.0, LandmarkManager::kNewMapEntry, camera_, &state_, &stats_,
                                 &result_);
  }

  VislamOptions options_;
  FilterState state_{StateLayout()};
  StereoCamera camera_{testing::kittiLikeCalibration()};
  LandmarkManager landmarks_{options_};
  EstimatorStats stats_;
  FeedResult result_;
  Eigen::Matrix4d world_T_imu_;
};

TEST_F(LandmarkManagerTest, InitializesAtTheSeenPointWithTheStereoDepthsUncertainty) {
  const int head = state_.dim();
  const Eigen::Vector3d near = worldPoint(10.0, 2.0), far = worldPoint(40.0, 2.0);
  ASSERT_TRUE(initialize(observe(7, near)));
  ASSERT_TRUE(initialize(observe(9, far)));
  EXPECT_EQ(state_.dim(), head + 6);
  EXPECT_EQ(landmarks_.activeCount(), 2u);
  ASSERT_EQ(landmarks_.find(7), std::optional<size_t>(0));
  ASSERT_EQ(landmarks_.find(9), std::optional<size_t>(1));
  EXPECT_LT((state_.landmark(0) - near).norm(), 1e-9);
  EXPECT_LT((state_.landmark(1) - far).norm(), 1e-9);
  ASSERT_EQ(landmarks_.map().size(), 2u);
  EXPECT_EQ(landmarks_.map()[1].id, 9u);
  EXPECT_TRUE(landmarks_.map()[1].active);
  // Along the ray (the IMU's x here) the stereo depth's variance grows as depth^4: 4^4 times.
  const double near_var = landmarks_.map()[0].covariance(0, 0);
  const double far_var = landmarks_.map()[1].covariance(0, 0);
  EXPECT_GT(far_var / near_var, 0.5 * 256.0);
  EXPECT_LT(far_var / near_var, 2.0 * 256.0);
  // SLAM: the new landmark is correlated with the pose it was seen from.
  const int row = state_.layout().landmarkRow(0);
  const Eigen::Matrix3d landmark_position = state_.covariance().block(row, 0, 3, 3);
  EXPECT_GT(landmark_position.norm(), 1e-3);
  EXPECT_EQ(stats_.get(Counter::kLandmarkInitialized), 2u);
}

TEST_F(LandmarkManagerTest, RefusesBadDisparityDepthAndTracksBeyondTheCap) {
  StereoObservation behind = observe(1, worldPoint(10.0, 0.0));
  behind.u_right = behind.u_left + 2.0;  // negative disparity
  EXPECT_FALSE(initialize(behind));
  EXPECT_EQ(stats_.get(Counter::kObsDisparity), 1u);
  EXPECT_FALSE(initialize(observe(2, worldPoint(200.0, 0.0))));  // beyond landmarks/max_depth
  EXPECT_EQ(stats_.get(Counter::kObsDepth), 1u);
  EXPECT_EQ(result_.observations_rejected, 2);
  for (uint32_t id = 3; id <= 5; ++id)
    EXPECT_TRUE(initialize(observe(id, worldPoint(10.0 + id, 0.0))));
  EXPECT_FALSE(initialize(observe(6, worldPoint(20.0, 0.0))));  // landmarks/max_active 3
  EXPECT_EQ(stats_.get(Counter::kObsWaiting), 1u);
  EXPECT_EQ(landmarks_.activeCount(), 3u);
  EXPECT_FALSE(landmarks_.find(6).has_value());
}

TEST_F(LandmarkManagerTest, AnEndedTrackLeavesTheStateAndStaysInTheMap) {
  for (uint32_t id : {4u, 5u, 6u}) ASSERT_TRUE(initialize(observe(id, worldPoint(8.0 + id, 1.0))));
  const Eigen::Vector3d kept = state_.landmark(2);
  const int dim = state_.dim();
  // Track 5 absent for one frame (max_track_gap 1): it stays; an empty frame does not count.
  std::vector<bool> ended = landmarks_.endedTracks({4, 6}, false);
  EXPECT_EQ(ended, std::vector<bool>({false, false, false}));
  ended = landmarks_.endedTracks({}, true);
  EXPECT_EQ(ended, std::vector<bool>({false, false, false}));
  ended = landmarks_.endedTracks({4, 6}, false);  // absent a second frame: ended
  EXPECT_EQ(ended, std::vector<bool>({false, true, false}));
  EXPECT_EQ(landmarks_.endTracks(ended, &state_, &stats_), 1);
  EXPECT_EQ(state_.dim(), dim - 3);
  EXPECT_FALSE(landmarks_.find(5).has_value());
  ASSERT_EQ(landmarks_.find(6), std::optional<size_t>(1));  // renumbered
  EXPECT_EQ(state_.landmark(1), kept);
  ASSERT_EQ(landmarks_.map().size(), 3u);
  EXPECT_FALSE(landmarks_.map()[1].active);
  EXPECT_EQ(landmarks_.map()[1].id, 5u);
  EXPECT_EQ(stats_.get(Counter::kLandmarkMarginalized), 1u);
  // A restart leaves the state without counting as marginalized, and reuses its map entry.
  LandmarkDecisions decisions;
  decisions.restart.push_back(0);
  landmarks_.apply(decisions, &state_, &stats_, &result_);
  EXPECT_EQ(landmarks_.activeCount(), 1u);
  EXPECT_EQ(stats_.get(Counter::kLandmarkMarginalized), 1u);
  EXPECT_EQ(stats_.get(Counter::kLandmarkReinitialized), 1u);
  ASSERT_TRUE(landmarks_.initialize(observe(4, worldPoint(12.0, 1.0)), 2.0, 0, camera_, &state_,
                                    &stats_, &result_));
  EXPECT_EQ(landmarks_.map().size(), 3u);
  EXPECT_TRUE(landmarks_.map()[0].active);
}

}  // namespace
}  // namespace ekf_vislam
