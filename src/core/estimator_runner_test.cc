// EstimatorRunner: stamp order, lazy propagation, the propagated copy, latency, saving.
#include "ekf_vislam/core/estimator_runner.h"

#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

namespace ekf_vislam {
namespace {

// A KITTI-like camera looking along the IMU's x axis, at the IMU's origin.
StereoCalibration forwardCamera() {
  StereoCalibration c = testing::kittiLikeCalibration();
  c.baseline = 0.5379;
  c.cam_T_imu.translation().setZero();
  return c;
}

FeatureFrame frameSeeing(double stamp, const Eigen::Vector3d& p_imu, const StereoCalibration& c) {
  const Eigen::Vector3d q = c.cam_T_imu * p_imu;
  StereoObservation f;
  f.id = 1;
  f.u_left = c.fx * q.x() / q.z() + c.cx;
  f.v_left = f.v_right = c.fy * q.y() / q.z() + c.cy;
  f.u_right = c.fx * (q.x() - c.baseline) / q.z() + c.cx;
  FeatureFrame frame;
  frame.stamp = stamp;
  frame.features.push_back(f);
  return frame;
}

std::string tempDir() {
  char pattern[] = "/tmp/ekf_vislam_runner_test_XXXXXX";
  const char* dir = ::mkdtemp(pattern);
  return dir ? dir : "";
}

bool fileExists(const std::string& path) {
  struct stat info;
  return ::stat(path.c_str(), &info) == 0;
}

TEST(EstimatorRunner, FeedsInStampOrderAndRecordsTheTrajectory) {
  EstimatorRunner runner{VislamOptions(), MeasurementSequencer::Options()};
  const StereoCalibration calibration = forwardCamera();
  std::string error;
  ASSERT_TRUE(runner.estimator().setCalibration(calibration, &error)) << error;
  std::vector<std::pair<bool, double>> seen;
  const auto observer = [&](const EstimatorRunner::Processed& p) {
    seen.emplace_back(p.kind == EstimatorRunner::Kind::kFrame, p.stamp);
    EXPECT_FALSE(p.without_calibration);
  };
  for (int k = 0; k < 5; ++k) {
    const double t = 0.1 * k;
    TwistData twist;
    twist.stamp = t;
    twist.v_imu.x() = 1.0;
    // The frame of a stamp arrives before its twist: the sequencer puts the twist first.
    runner.push(frameSeeing(t, Eigen::Vector3d(20.0 - t, 0.5, 0.2), calibration));
    runner.processReady(observer);
    runner.push(twist);
    runner.processReady(observer);
  }
  runner.flush(observer);
  ASSERT_EQ(seen.size(), 10u);
  for (size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].first, i % 2 == 1) << i;  // twist first at equal stamps
    EXPECT_DOUBLE_EQ(seen[i].second, 0.1 * static_cast<double>(i / 2)) << i;
  }
  EXPECT_EQ(runner.framesFed(), 5u);
  EXPECT_EQ(runner.twistsFed(), 5u);
  ASSERT_EQ(runner.trajectory().size(), 5u);
  EXPECT_EQ(runner.times().count(), 5u);
  EXPECT_NEAR(runner.trajectory().back().world_T_imu.translation().x(), 0.4, 0.2);
  const RunSummary summary = runner.summary();
  EXPECT_EQ(summary.frames, 5u);
  EXPECT_EQ(summary.mode, "slam");
  EXPECT_NEAR(summary.data_s, 0.4, 1e-9);
  EXPECT_GE(summary.landmarks_total, 1u);

  const std::string dir = tempDir();
  ASSERT_FALSE(dir.empty());
  ASSERT_TRUE(runner.save(dir + "/run/a", &error)) << error;  // creates folders
  for (const char* name : {"trajectory.tum", "landmarks.csv", "stats.json"}) {
    EXPECT_TRUE(fileExists(dir + "/run/a/" + name)) << name;
  }
  std::ifstream tum(dir + "/run/a/trajectory.tum");
  int lines = 0;
  for (std::string line; std::getline(tum, line);) lines += line.empty() ? 0 : 1;
  EXPECT_EQ(lines, 5);

  runner.reset();
  EXPECT_TRUE(runner.trajectory().empty());
  EXPECT_TRUE(runner.estimator().landmarks().empty());
  EXPECT_TRUE(runner.estimator().hasCalibration());  // kept
  EXPECT_EQ(runner.buffered(), 0u);
  std::system(("rm -rf " + dir).c_str());
}

// A short synthetic drive (twist k and frame k share stamp k).
const testing::Scenario& shortDrive() {
  static const testing::Scenario drive = [] {
    testing::ScenarioOptions options;
    options.frames = 80;
    return testing::makeScenario(options);
  }();
  return drive;
}

EstimatorRunner startedRunner() {
  EstimatorRunner runner{testing::matchedOptions(testing::ScenarioOptions()),
                         MeasurementSequencer::Options{10.0, 2000}};
  EXPECT_TRUE(runner.estimator().setCalibration(shortDrive().calibration));
  return runner;
}

double maxPositionDifference(const std::vector<StampedPose>& a, const std::vector<StampedPose>& b) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].stamp != b[i].stamp) return std::numeric_limits<double>::infinity();
    worst =
        std::max(worst, (a[i].world_T_imu.translation() - b[i].world_T_imu.translation()).norm());
  }
  return worst;
}

TEST(EstimatorRunner, ResultDoesNotDependOnArrivalOrderWithinTheWindow) {
  const testing::Scenario& s = shortDrive();
  const size_t n = s.frames.size();
  EstimatorRunner in_order = startedRunner();
  for (size_t k = 0; k < n; ++k) {
    in_order.push(s.twists[k]);
    in_order.processReady();
    in_order.push(s.frames[k]);
    in_order.processReady();
  }
  in_order.flush();
  // A stalled reader: backlogs of 20 messages per stream read one stream at a time, twists first
  // in one block and frames first in the next.
  EstimatorRunner stalled = startedRunner();
  for (size_t block = 0; block < n; block += 20) {
    const size_t end = std::min(n, block + 20);
    for (int pass = 0; pass < 2; ++pass) {
      const bool twists = (pass == 0) == ((block / 20) % 2 == 0);
      for (size_t k = block; k < end; ++k) {
        if (twists) {
          stalled.push(s.twists[k]);
        } else {
          stalled.push(s.frames[k]);
        }
        stalled.processReady();
      }
    }
  }
  stalled.flush();
  ASSERT_EQ(in_order.trajectory().size(), n);
  EXPECT_EQ(maxPositionDifference(in_order.trajectory(), stalled.trajectory()), 0.0);
  for (Counter c : {Counter::kFrameStale, Counter::kTwistLate, Counter::kTwistUsed,
                    Counter::kFrameUsed, Counter::kObservationUpdate}) {
    EXPECT_EQ(in_order.estimator().stats().get(c), stalled.estimator().stats().get(c))
        << counterName(c);
  }
  EXPECT_EQ(stalled.estimator().stats().get(Counter::kFrameStale), 0u);
  EXPECT_EQ(stalled.estimator().stats().get(Counter::kTwistLate), 0u);
  EXPECT_EQ(stalled.latencies().count(), n);
}

// Images stamped `lag` s after they were taken (a camera stamped on arrival, lag > 0) or before:
// with extrinsic/camera_time_offset = -lag the runner uses each frame when its images were taken
// on the twist's clock, and the drive is the one of images stamped in sync, bit for bit (lags of
// 2^-4 s keep the stamps exact); ignored, the offset costs accuracy.
TEST(EstimatorRunner, ACameraTimeOffsetRestampsFramesToWhenTheImagesWereTaken) {
  const testing::Scenario& s = shortDrive();
  auto play = [&s](double lag, double camera_time_offset) {
    VislamOptions options = testing::matchedOptions(testing::ScenarioOptions());
    options.extrinsic.camera_time_offset = camera_time_offset;
    EstimatorRunner runner{options, MeasurementSequencer::Options{10.0, 2000}};
    EXPECT_TRUE(runner.estimator().setCalibration(s.calibration));
    for (size_t k = 0; k < s.frames.size(); ++k) {
      FeatureFrame frame = s.frames[k];
      frame.stamp += lag;
      runner.push(s.twists[k]);
      runner.push(frame);
      runner.processReady();
    }
    runner.flush();
    return runner.trajectory();
  };
  // Position RMSE against the ground truth of the frames, frame 0 left out (stamped early, without
  // the offset, it comes before the first twist and is rejected); `late` s: how much later than
  // the images the poses are stamped.
  auto rmse = [&s](const std::vector<StampedPose>& trajectory, double late) {
    const double period = testing::ScenarioOptions().dt;
    double sq = 0.0;
    int n = 0;
    for (const StampedPose& pose : trajectory) {
      const long k = std::lround((pose.stamp - late - s.frames[0].stamp) / period);
      if (k < 1 || k >= static_cast<long>(s.world_T_imu.size())) continue;
      sq +=
          (pose.world_T_imu.translation() - s.world_T_imu[k].topRightCorner<3, 1>()).squaredNorm();
      ++n;
    }
    return std::sqrt(sq / std::max(n, 1));
  };
  const std::vector<StampedPose> in_sync = play(0.0, 0.0);
  for (const double lag : {0.0625, -0.0625}) {
    const std::vector<StampedPose> corrected = play(lag, -lag);
    const std::vector<StampedPose> ignored = play(lag, 0.0);
    EXPECT_EQ(maxPositionDifference(corrected, in_sync), 0.0) << "lag " << lag;
    std::printf(
        "images stamped %+.4f s: position RMSE %.3f m with the offset, %.3f m without "
        "(%.3f m at the images' times), %.3f m in sync\n",
        lag, rmse(corrected, 0.0), rmse(ignored, 0.0), rmse(ignored, lag), rmse(in_sync, 0.0));
    EXPECT_GT(rmse(ignored, 0.0), 2.0 * rmse(corrected, 0.0)) << "lag " << lag;
  }
}

// ~reset, or a bag played again: the drive after a reset gives a fresh runner's trajectory and
// reported covariance, bit for bit (nothing learned before the reset is kept).
TEST(EstimatorRunner, AfterAResetTheSameDriveGivesAFreshRunnersResult) {
  const testing::Scenario& s = shortDrive();
  auto play = [&s](EstimatorRunner* runner) {
    for (size_t k = 0; k < s.frames.size(); ++k) {
      runner->push(s.twists[k]);
      runner->push(s.frames[k]);
      runner->processReady();
    }
    runner->flush();
  };
  EstimatorRunner fresh = startedRunner();
  play(&fresh);
  EstimatorRunner again = startedRunner();
  play(&again);
  again.reset();
  play(&again);
  ASSERT_EQ(again.trajectory().size(), s.frames.size());
  EXPECT_EQ(maxPositionDifference(fresh.trajectory(), again.trajectory()), 0.0);
  double covariance_difference = 0.0;
  for (size_t k = 0; k < s.frames.size(); ++k) {
    covariance_difference = std::max(
        covariance_difference,
        (fresh.trajectoryCovariance()[k] - again.trajectoryCovariance()[k]).cwiseAbs().maxCoeff());
  }
  EXPECT_EQ(covariance_difference, 0.0);
}

TEST(EstimatorRunner, AnAccelerometerStreamAheadOrBehindGivesTheSameResult) {
  // The drive with an accelerometer, fed in stamp order, and again with the accelerometer ten
  // samples ahead of the twists and the frames, the propagated copy on and the outputs read
  // between messages (as the node's timers do): the same trajectory, bit for bit.
  testing::ScenarioOptions options;
  options.frames = 200;
  options.accel_noise = 0.05;
  options.up_world = Eigen::Vector3d(0.02, -0.01, 1.0);
  const testing::Scenario s = testing::makeScenario(options);
  auto started = [&] {
    EstimatorRunner runner{testing::matchedOptions(options),
                           MeasurementSequencer::Options{10.0, 2000}};
    EXPECT_TRUE(runner.estimator().setCalibration(s.calibration));
    return runner;
  };
  const size_t n = s.frames.size();
  EstimatorRunner in_order = started();
  for (size_t k = 0; k < n; ++k) {
    in_order.push(s.accels[k]);
    in_order.push(s.twists[k]);
    in_order.push(s.frames[k]);
    in_order.processReady();
  }
  in_order.flush();
  EstimatorRunner ahead = started();
  ahead.enablePreview(true);
  double read = 0.0;
  for (size_t k = 0; k < n + 10; ++k) {
    if (k < n) ahead.push(s.accels[k]);
    ahead.processReady();
    if (k >= 10) {
      ahead.push(s.frames[k - 10]);  // the frame before its twist
      ahead.processReady();
      ahead.push(s.twists[k - 10]);
      ahead.processReady();
    }
    read += ahead.estimator().poseCovarianceWorld().trace() +
            ahead.estimator().accelBiasSigma().sum() + ahead.estimator().stateCovariance().trace();
  }
  ahead.flush();
  EXPECT_TRUE(std::isfinite(read));
  ASSERT_EQ(in_order.trajectory().size(), n);
  EXPECT_GT(in_order.estimator().stats().get(Counter::kGravityUpdate), 10u);
  EXPECT_EQ(maxPositionDifference(in_order.trajectory(), ahead.trajectory()), 0.0);
  for (Counter c : {Counter::kAccelUsed, Counter::kAccelLate, Counter::kGravityUpdate,
                    Counter::kTwistLate, Counter::kFrameStale, Counter::kObservationUpdate}) {
    EXPECT_EQ(in_order.estimator().stats().get(c), ahead.estimator().stats().get(c))
        << counterName(c);
  }
  EXPECT_EQ(in_order.estimator().accelBias(), ahead.estimator().accelBias());
}

TEST(EstimatorRunner, PropagatedCopyFollowsEveryTwistAndNeverChangesTheFilter) {
  const testing::Scenario& s = shortDrive();
  EstimatorRunner runner = startedRunner();
  runner.enablePreview(true);
  VislamEstimator eager(testing::matchedOptions(testing::ScenarioOptions()));
  ASSERT_TRUE(eager.setCalibration(s.calibration));
  for (size_t k = 0; k + 1 < s.frames.size(); k += 2) {
    runner.push(s.twists[k]);
    runner.processReady();
    runner.push(s.frames[k]);
    runner.processReady();
    eager.feedTwist(s.twists[k]);
    eager.feedFeatures(s.frames[k]);
    // The next twist arrives before its frame: odometry from the copy, filter untouched.
    const Eigen::Isometry3d filter_before = runner.estimator().worldTImu();
    const Eigen::MatrixXd covariance_before = runner.estimator().stateCovariance();
    runner.push(s.twists[k + 1]);
    runner.processReady();
    EXPECT_TRUE(runner.estimator().worldTImu().isApprox(filter_before, 0.0)) << k;
    EXPECT_EQ((runner.estimator().stateCovariance() - covariance_before).norm(), 0.0) << k;
    eager.feedTwist(s.twists[k + 1]);
    const EstimatorRunner::Preview& preview = runner.preview();
    ASSERT_TRUE(preview.valid);
    EXPECT_EQ(preview.stamp, s.twists[k + 1].stamp);
    EXPECT_LT((preview.world_T_imu.matrix() - eager.worldTImu().matrix()).norm(), 1e-12) << k;
    EXPECT_LT((preview.pose_covariance_world - eager.poseCovarianceWorld()).norm(), 1e-12) << k;
    // The filter catches up when the frame comes.
    runner.push(s.frames[k + 1]);
    runner.processReady();
    eager.feedFeatures(s.frames[k + 1]);
    EXPECT_LT((runner.estimator().worldTImu().matrix() - eager.worldTImu().matrix()).norm(), 1e-12);
  }
}

TEST(EstimatorRunner, PropagatedCopyShowsTheFrameItsTwistReleased) {
  // Each frame comes before the twist of its stamp and waits for it in the sequencer: the twist
  // releases it, and the copy then shows the updated filter, not the one before the frame.
  const testing::Scenario& s = shortDrive();
  EstimatorRunner runner = startedRunner();
  runner.enablePreview(true);
  for (size_t k = 0; k < 20; ++k) {
    runner.push(s.frames[k]);
    runner.processReady();
    const size_t frames_before = runner.trajectory().size();
    runner.push(s.twists[k]);
    runner.processReady();
    ASSERT_EQ(runner.trajectory().size(), frames_before + 1) << k;  // the frame went in
    const EstimatorRunner::Preview& preview = runner.preview();
    if (!preview.valid) continue;  // (before the filter starts)
    EXPECT_EQ(preview.stamp, runner.estimator().time()) << k;
    EXPECT_LT((preview.world_T_imu.matrix() - runner.estimator().worldTImu().matrix()).norm(),
              1e-12)
        << k;
    EXPECT_LT((preview.pose_covariance_world - runner.estimator().poseCovarianceWorld()).norm(),
              1e-12)
        << k;
  }
  EXPECT_TRUE(runner.preview().valid);
}

TEST(EstimatorRunner, FlagsFramesWithoutCalibration) {
  EstimatorRunner runner{VislamOptions(), MeasurementSequencer::Options()};
  int without = 0;
  TwistData twist;
  twist.stamp = 1.0;
  runner.push(twist);
  runner.push(frameSeeing(1.0, Eigen::Vector3d(20.0, 0.0, 0.0), forwardCamera()));
  runner.flush([&](const EstimatorRunner::Processed& p) { without += p.without_calibration; });
  EXPECT_EQ(without, 1);
  EXPECT_EQ(runner.framesWithoutCalibration(), 1u);
  EXPECT_EQ(runner.estimator().stats().get(Counter::kFrameNoCalibration), 1u);
}

// The same drive pushed twice, as when a bag is played again: with the time-jump reset the
// runner starts over at the second pass and uses every frame of it; without, all are stale.
TEST(EstimatorRunner, TimeGoingBackRestartsTheRunWhenEnabled) {
  for (const double threshold : {1.0, 0.0}) {
    EstimatorRunner runner{VislamOptions(), MeasurementSequencer::Options()};
    if (threshold > 0.0) runner.enableTimeJumpReset(threshold);
    const StereoCalibration calibration = forwardCamera();
    std::string error;
    ASSERT_TRUE(runner.estimator().setCalibration(calibration, &error)) << error;
    for (int pass = 0; pass < 2; ++pass) {
      for (int k = 0; k < 30; ++k) {
        const double t = 100.0 + 0.1 * k;
        TwistData twist;
        twist.stamp = t;
        twist.v_imu.x() = 1.0;
        runner.push(twist);
        runner.push(frameSeeing(t, Eigen::Vector3d(20.0 - (t - 100.0), 0.5, 0.2), calibration));
        runner.processReady();
      }
    }
    runner.flush();
    const uint64_t stale = runner.estimator().stats().get(Counter::kFrameStale);
    if (threshold > 0.0) {
      EXPECT_EQ(runner.timeJumpResets(), 1u);
      EXPECT_NEAR(runner.lastTimeJump(), 2.9, 1e-9);
      EXPECT_EQ(stale, 0u);
      ASSERT_EQ(runner.trajectory().size(), 30u);  // the second pass only
      EXPECT_DOUBLE_EQ(runner.trajectory().front().stamp, 100.0);
      EXPECT_DOUBLE_EQ(runner.summary().extra.at("time_jump_resets"), 1.0);
    } else {
      EXPECT_EQ(runner.timeJumpResets(), 0u);
      EXPECT_GE(stale, 29u);
    }
  }
}

TEST(EstimatorRunner, SaveFailsWithAMessage) {
  EstimatorRunner runner{VislamOptions(), MeasurementSequencer::Options()};
  std::string error;
  EXPECT_FALSE(runner.save("", &error));
  EXPECT_FALSE(error.empty());
  error.clear();
  EXPECT_FALSE(runner.save("/proc/ekf_vislam_cannot_create", &error));
  EXPECT_NE(error.find("/proc"), std::string::npos) << error;
}

}  // namespace
}  // namespace ekf_vislam
