// The estimator at a stop (standstill/): a simulated drive that stands still for 30 s.
#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/vislam_estimator.h"
#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace ekf_vislam {
namespace {

using testing::Scenario;
using testing::ScenarioOptions;

constexpr int kStopFirst = 150;
constexpr int kStopFrames = 300;

ScenarioOptions stopScenario() {
  ScenarioOptions o;
  o.frames = 600;
  o.stop_first_frame = kStopFirst;
  o.stop_frames = kStopFrames;
  return o;
}

struct StopRun {
  double ate_m = 0.0;
  double mean_pose_nees = 0.0;
  Eigen::Matrix4d at_stop_start, at_stop_end;  ///< estimates 10 frames in and at the last frame
  Eigen::Vector3d gyro_bias_at_stop_end = Eigen::Vector3d::Zero();
  uint64_t frames_at_rest = 0, twists_at_rest = 0;
  double mean_speed = 0.0;  ///< VislamEstimator::meanTwistSpeed at the end
};

StopRun drive(const Scenario& s, const VislamOptions& options) {
  VislamEstimator estimator(options);
  EXPECT_TRUE(estimator.setCalibration(s.calibration));
  StopRun r;
  double squares = 0.0, nees = 0.0;
  for (size_t k = 0; k < s.frames.size(); ++k) {
    estimator.feedTwist(s.twists[k]);
    estimator.feedFeatures(s.frames[k]);
    const Eigen::Matrix4d T = estimator.worldTImu().matrix();
    squares += (T.topRightCorner<3, 1>() - s.world_T_imu[k].topRightCorner<3, 1>()).squaredNorm();
    if (k > 0) {
      Vector6d e;
      e.head<3>() = s.world_T_imu[k].topRightCorner<3, 1>() - T.topRightCorner<3, 1>();
      e.tail<3>() =
          se3::logSO3(s.world_T_imu[k].topLeftCorner<3, 3>() * T.topLeftCorner<3, 3>().transpose());
      nees += e.dot(estimator.poseCovarianceWorld().ldlt().solve(e));
    }
    if (k == kStopFirst + 10) r.at_stop_start = T;
    if (k == kStopFirst + kStopFrames - 1) {
      r.at_stop_end = T;
      r.gyro_bias_at_stop_end = estimator.twistBias().tail<3>();
    }
  }
  r.ate_m = std::sqrt(squares / s.frames.size());
  r.mean_pose_nees = nees / (s.frames.size() - 1);
  r.frames_at_rest = estimator.stats().get(Counter::kFrameAtRest);
  r.twists_at_rest = estimator.stats().get(Counter::kTwistAtRest);
  r.mean_speed = estimator.meanTwistSpeed();
  return r;
}

double movedM(const StopRun& r) {
  return (r.at_stop_end.topRightCorner<3, 1>() - r.at_stop_start.topRightCorner<3, 1>()).norm();
}

double turnedDeg(const StopRun& r) {
  return se3::logSO3(r.at_stop_end.topLeftCorner<3, 3>() *
                     r.at_stop_start.topLeftCorner<3, 3>().transpose())
             .norm() *
         180.0 / M_PI;
}

TEST(Standstill, AStopHoldsThePoseAndMeasuresTheGyroBias) {
  const ScenarioOptions scenario = stopScenario();
  const Scenario s = testing::makeScenario(scenario);
  VislamOptions held_options = testing::matchedOptions(scenario);
  VislamOptions driven_options = held_options;
  driven_options.standstill.enabled = false;
  const StopRun held = drive(s, held_options);
  const StopRun driven = drive(s, driven_options);
  const Eigen::Vector3d bias_error_held = held.gyro_bias_at_stop_end - scenario.gyro_bias;
  const Eigen::Vector3d bias_error_driven = driven.gyro_bias_at_stop_end - scenario.gyro_bias;
  std::printf(
      "held: ATE %.4f m, pose NEES %.2f, moved %.4f m, turned %.4f deg, bias error "
      "%.5f %.5f %.5f rad/s, %lu frames and %lu twists at rest\n",
      held.ate_m, held.mean_pose_nees, movedM(held), turnedDeg(held), bias_error_held.x(),
      bias_error_held.y(), bias_error_held.z(), static_cast<unsigned long>(held.frames_at_rest),
      static_cast<unsigned long>(held.twists_at_rest));
  std::printf(
      "driven: ATE %.4f m, pose NEES %.2f, moved %.4f m, turned %.4f deg, bias error "
      "%.5f %.5f %.5f rad/s\n",
      driven.ate_m, driven.mean_pose_nees, movedM(driven), turnedDeg(driven), bias_error_driven.x(),
      bias_error_driven.y(), bias_error_driven.z());
  // Every frame of the stop but the first ones is recognized (the ramp's last frames move less
  // than the bound too), and each twist sample in it measures the bias.
  EXPECT_GE(held.frames_at_rest, 290u);
  EXPECT_LE(held.frames_at_rest, static_cast<uint64_t>(kStopFrames));
  EXPECT_GE(held.twists_at_rest, 290u);
  // Driven through, the twist's noise (0.5 m/s per sample) moves pose and map together by
  // decimetres over the stop; held, the pose stays.
  EXPECT_GT(movedM(driven), 0.1);
  EXPECT_LT(movedM(held), 0.02);
  EXPECT_LT(turnedDeg(held), 0.03);
  EXPECT_LT(held.ate_m, 0.8 * driven.ate_m);
  EXPECT_LT(held.mean_pose_nees, 3.0);
  // 300 samples of 0.05 rad/s measure the bias to 0.003 rad/s per axis.
  EXPECT_LT(bias_error_held.cwiseAbs().maxCoeff(), 0.009);
  // The mean speed (the slow-drive warning's) is the drive's: the samples held at rest are left
  // out; driven through, the stop halves it.
  double moving_sum = 0.0;
  int moving = 0;
  for (size_t k = 0; k < s.twists.size(); ++k) {
    if (s.still[k]) continue;
    moving_sum += std::abs(s.twists[k].v_imu.x());
    ++moving;
  }
  EXPECT_NEAR(held.mean_speed, moving_sum / moving, 0.01 * moving_sum / moving);
  EXPECT_LT(driven.mean_speed, 0.6 * held.mean_speed);
}

TEST(Standstill, ADriveWithoutAStopIsNotChanged) {
  const ScenarioOptions scenario;
  const Scenario s = testing::makeScenario(scenario);
  VislamOptions on = testing::matchedOptions(scenario);
  VislamOptions off = on;
  off.standstill.enabled = false;
  VislamEstimator a(on), b(off);
  ASSERT_TRUE(a.setCalibration(s.calibration));
  ASSERT_TRUE(b.setCalibration(s.calibration));
  for (size_t k = 0; k < s.frames.size(); ++k) {
    for (VislamEstimator* e : {&a, &b}) {
      e->feedTwist(s.twists[k]);
      e->feedFeatures(s.frames[k]);
    }
    ASSERT_EQ(a.worldTImu().matrix(), b.worldTImu().matrix()) << "frame " << k;
  }
  EXPECT_EQ(a.stats().get(Counter::kFrameAtRest), 0u);
  EXPECT_EQ(a.stats().get(Counter::kTwistAtRest), 0u);
}

}  // namespace
}  // namespace ekf_vislam
