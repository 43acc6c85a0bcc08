#include "ekf_vislam/core/input_screening.h"

#include "testing/synthetic_scenario.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>

namespace ekf_vislam {
namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

class InputScreeningTest : public ::testing::Test {
 protected:
  VislamOptions options_;
  InputScreening screening_{options_};
  StereoCamera camera_{testing::kittiLikeCalibration()};  // 1241 x 376
};

TEST_F(InputScreeningTest, TwistsNonFiniteOrBeyondTheLimitsAreRefusedWithTheReason) {
  TwistData twist;
  twist.stamp = 1.0;
  twist.v_imu = Eigen::Vector3d(8.0, 0.1, 0.0);
  twist.w_imu = Eigen::Vector3d(0.0, 0.0, 0.3);
  std::string why;
  EXPECT_FALSE(screening_.checkTwist(twist, &why).has_value());
  TwistData nan = twist;
  nan.w_imu.y() = kNaN;
  EXPECT_EQ(screening_.checkTwist(nan, &why), Counter::kTwistNonFinite);
  TwistData fast = twist;
  fast.v_imu.x() = options_.limits.max_linear_speed + 1.0;
  EXPECT_EQ(screening_.checkTwist(fast, &why), Counter::kTwistImplausible);
  EXPECT_NE(why.find("limits/max_linear_speed"), std::string::npos) << why;
  TwistData spinning = twist;
  spinning.w_imu.z() = options_.limits.max_angular_speed * 1.01;
  EXPECT_EQ(screening_.checkTwist(spinning, &why), Counter::kTwistImplausible);
}

TEST_F(InputScreeningTest, AccelerometerSamplesOutsideWhatOneReadsAreRefused) {
  AccelerometerData sample;
  sample.stamp = 1.0;
  sample.f_imu = Eigen::Vector3d(0.3, -0.2, options_.gravity.magnitude);
  std::string why;
  EXPECT_FALSE(screening_.checkAccelerometer(sample, &why).has_value());
  for (const double scale : {0.0, 0.25, 4.5}) {
    AccelerometerData odd = sample;
    odd.f_imu *= scale;  // an empty field, or another unit
    EXPECT_EQ(screening_.checkAccelerometer(odd, &why), Counter::kAccelImplausible) << scale;
  }
  AccelerometerData nan = sample;
  nan.covariance(1, 1) = kNaN;
  EXPECT_EQ(screening_.checkAccelerometer(nan, &why), Counter::kAccelNonFinite);
}

TEST_F(InputScreeningTest, ObservationsAreRefusedForTheFirstProblemAndCounted) {
  const StereoObservation good{1, 600.0, 180.0, 580.0, 180.4};
  EXPECT_FALSE(screening_.checkObservation(good, camera_).has_value());
  StereoObservation f = good;
  f.v_right = kNaN;
  EXPECT_EQ(screening_.checkObservation(f, camera_), Counter::kObsNonFinite);
  f = good;
  f.u_left = 1300.0;  // right of the 1241-px image
  EXPECT_EQ(screening_.checkObservation(f, camera_), Counter::kObsOutsideImage);
  f = good;
  f.v_right = good.v_left + options_.limits.max_row_difference_px + 0.5;
  EXPECT_EQ(screening_.checkObservation(f, camera_), Counter::kObsRowMismatch);
  f = good;
  f.u_right = good.u_left - 0.5 * options_.landmarks.min_disparity_px;
  EXPECT_EQ(screening_.checkObservation(f, camera_), Counter::kObsDisparity);

  EstimatorStats stats;
  FeedResult result;
  EXPECT_TRUE(screening_.screen(good, camera_, &stats, &result));
  EXPECT_FALSE(screening_.screen(f, camera_, &stats, &result));
  EXPECT_EQ(stats.get(Counter::kObsDisparity), 1u);
  EXPECT_EQ(result.observations_rejected, 1);
}

}  // namespace
}  // namespace ekf_vislam
