// Unit tests of TfWaitingQueue: messages in a frame tf does not know yet wait for it in message
// time and in wall time, so a fast bag on a loaded machine loses nothing (no roscore).
#include "ekf_vislam/ros/tf_waiting_queue.h"

#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <sensor_msgs/Imu.h>

#include <vector>

namespace ekf_vislam {
namespace {

using Queue = TfWaitingQueue<sensor_msgs::Imu>;

/// An imu/data queue for body frame base_link, its tf buffer (empty until addStaticTransform),
/// and the stamps of the samples used and dropped so far.
class TfWaitingQueueTest : public ::testing::Test {
 protected:
  /// Pushes a sample stamped `stamp` in `frame` that arrived `ms` after the start, and drains
  /// the queue then.
  void pushAndDrain(double stamp, int ms, const std::string& frame = "imu") {
    sensor_msgs::Imu::Ptr msg(new sensor_msgs::Imu);
    msg->header.stamp = ros::Time(stamp);
    msg->header.frame_id = frame;
    queue_.push(msg, start_ + 1e-3 * ms);
    drainAt(ms);
  }
  void drainAt(int ms) {
    queue_.drain(
        1.0, &transforms_, [](const sensor_msgs::Imu& m) { return m.header.frame_id; },
        [&](const sensor_msgs::Imu& m, const Eigen::Isometry3d& body_T_frame) {
          EXPECT_NEAR(body_T_frame.translation().x(), m.header.frame_id == "imu" ? 1.2 : 0.0,
                      1e-12);
          used_.push_back(m.header.stamp.toSec());
        },
        [&](const sensor_msgs::Imu& m, const std::string&) {
          dropped_.push_back(m.header.stamp.toSec());
        },
        start_ + 1e-3 * ms);
  }
  void addStaticTransform() {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = "base_link";
    t.child_frame_id = "imu";
    t.transform.translation.x = 1.2;
    t.transform.rotation.w = 1.0;
    buffer_.setTransform(t, "test", true);
  }

  tf2::BufferCore buffer_;
  FixedFrameTransforms transforms_{&buffer_, "base_link"};
  Queue queue_{"imu/data"};
  const double start_ = steadyClockSeconds();
  std::vector<double> used_, dropped_;
};

TEST_F(TfWaitingQueueTest, AFastBagWaitsForALateTfInWallTimeAndLosesNothing) {
  // 60 samples, 6 s of message time, arriving within 0.6 s of wall time (a bag at 10x); the tf
  // comes 0.7 s after the first one. Message time alone would drop all but the last 11.
  for (int k = 0; k < 60; ++k) pushAndDrain(100.0 + 0.1 * k, 10 * k);
  EXPECT_TRUE(used_.empty());
  EXPECT_TRUE(dropped_.empty());  // 5.9 s of message time, but only 0.59 s of wall time
  EXPECT_EQ(queue_.size(), 60u);
  addStaticTransform();
  drainAt(700);
  ASSERT_EQ(used_.size(), 60u);
  for (int k = 0; k < 60; ++k) EXPECT_DOUBLE_EQ(used_[k], 100.0 + 0.1 * k);  // in order
  EXPECT_EQ(queue_.droppedWithoutTf(), 0u);
}

TEST_F(TfWaitingQueueTest, WithoutTfASampleIsDroppedOnceBothClocksHaveWaited) {
  // Real time: 10 Hz in both clocks for 2.5 s.
  for (int k = 0; k <= 25; ++k) pushAndDrain(100.0 + 0.1 * k, 100 * k);
  // Dropped: the samples more than 1 s older than the newest (100.0 .. 101.4) in both clocks.
  ASSERT_EQ(dropped_.size(), 15u);
  EXPECT_DOUBLE_EQ(dropped_.front(), 100.0);
  EXPECT_NEAR(dropped_.back(), 101.4, 1e-9);
  EXPECT_EQ(queue_.droppedWithoutTf(), 15u);
  EXPECT_EQ(queue_.size(), 11u);
  EXPECT_TRUE(used_.empty());
  // Once tf knows the frame the rest are used, then a sample in the body frame itself.
  addStaticTransform();
  pushAndDrain(102.6, 2600, "base_link");
  ASSERT_EQ(used_.size(), 12u);
  EXPECT_NEAR(used_.front(), 101.5, 1e-9);
  EXPECT_NEAR(used_.back(), 102.6, 1e-9);
  EXPECT_EQ(dropped_.size(), 15u);
}

}  // namespace
}  // namespace ekf_vislam
