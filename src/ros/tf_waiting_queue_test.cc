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
using std::chrono::milliseconds;

sensor_msgs::Imu::ConstPtr imuAt(double stamp, const std::string& frame) {
  sensor_msgs::Imu::Ptr msg(new sensor_msgs::Imu);
  msg->header.stamp = ros::Time(stamp);
  msg->header.frame_id = frame;
  return msg;
}

void addStaticTransform(tf2::BufferCore* buffer) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "base_link";
  t.child_frame_id = "imu";
  t.transform.translation.x = 1.2;
  t.transform.rotation.w = 1.0;
  buffer->setTransform(t, "test", true);
}

struct Drained {
  std::vector<double> used, dropped;
};

void drain(Queue* queue, FixedFrameTransforms* transforms, Queue::Clock::time_point now,
           Drained* out) {
  queue->drain(
      1.0, transforms, [](const sensor_msgs::Imu& m) { return m.header.frame_id; },
      [&](const sensor_msgs::Imu& m, const Eigen::Isometry3d& body_T_frame) {
        EXPECT_NEAR(body_T_frame.translation().x(), 1.2, 1e-12);
        out->used.push_back(m.header.stamp.toSec());
      },
      [&](const sensor_msgs::Imu& m, const std::string&) {
        out->dropped.push_back(m.header.stamp.toSec());
      },
      now);
}

TEST(TfWaitingQueue, AFastBagWaitsForALateTfInWallTimeAndLosesNothing) {
  // 60 samples, 6 s of message time, arriving within 0.6 s of wall time (a bag at 10x); the tf
  // comes 0.7 s after the first one.
  tf2::BufferCore buffer;
  FixedFrameTransforms transforms(&buffer, "base_link");
  Queue queue("imu/data");
  const Queue::Clock::time_point start = Queue::Clock::now();
  Drained out;
  for (int k = 0; k < 60; ++k) {
    const Queue::Clock::time_point arrival = start + milliseconds(10 * k);
    queue.push(imuAt(100.0 + 0.1 * k, "imu"), arrival);
    drain(&queue, &transforms, arrival, &out);
  }
  EXPECT_TRUE(out.used.empty());
  EXPECT_TRUE(out.dropped.empty());  // 5.9 s of message time, but only 0.59 s of wall time
  EXPECT_EQ(queue.size(), 60u);
  addStaticTransform(&buffer);
  drain(&queue, &transforms, start + milliseconds(700), &out);
  ASSERT_EQ(out.used.size(), 60u);
  for (int k = 0; k < 60; ++k) EXPECT_DOUBLE_EQ(out.used[k], 100.0 + 0.1 * k);  // in order
  EXPECT_EQ(queue.droppedWithoutTf(), 0u);
}

TEST(TfWaitingQueue, WithoutTfASampleIsDroppedOnceBothClocksHaveWaited) {
  tf2::BufferCore buffer;
  FixedFrameTransforms transforms(&buffer, "base_link");
  Queue queue("imu/data");
  const Queue::Clock::time_point start = Queue::Clock::now();
  Drained out;
  // Real time: 10 Hz in both clocks for 2.5 s.
  for (int k = 0; k <= 25; ++k) {
    const Queue::Clock::time_point arrival = start + milliseconds(100 * k);
    queue.push(imuAt(100.0 + 0.1 * k, "imu"), arrival);
    drain(&queue, &transforms, arrival, &out);
  }
  // Dropped: the samples more than 1 s older than the newest (100.0 .. 101.4) in both clocks.
  ASSERT_EQ(out.dropped.size(), 15u);
  EXPECT_DOUBLE_EQ(out.dropped.front(), 100.0);
  EXPECT_NEAR(out.dropped.back(), 101.4, 1e-9);
  EXPECT_EQ(queue.droppedWithoutTf(), 15u);
  EXPECT_EQ(queue.size(), 11u);
  // Samples in the body frame itself pass without tf, after those waiting before them.
  addStaticTransform(&buffer);
  queue.push(imuAt(102.6, "base_link"), start + milliseconds(2600));
  Drained after;
  queue.drain(
      1.0, &transforms, [](const sensor_msgs::Imu& m) { return m.header.frame_id; },
      [&](const sensor_msgs::Imu& m, const Eigen::Isometry3d&) {
        after.used.push_back(m.header.stamp.toSec());
      },
      [&](const sensor_msgs::Imu&, const std::string&) { ADD_FAILURE(); },
      start + milliseconds(2600));
  ASSERT_EQ(after.used.size(), 12u);
  EXPECT_NEAR(after.used.front(), 101.5, 1e-9);
  EXPECT_NEAR(after.used.back(), 102.6, 1e-9);
}

}  // namespace
}  // namespace ekf_vislam
