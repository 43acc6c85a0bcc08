#include "ekf_vislam/core/twist_combiner.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/core/yaml_parameter_source.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace ekf_vislam {
namespace {

AngularVelocitySample gyro(double stamp, const Eigen::Vector3d& w = Eigen::Vector3d::Zero()) {
  AngularVelocitySample sample;
  sample.stamp = stamp;
  sample.w_imu = w;
  return sample;
}

LinearVelocitySample wheel(double stamp, double forward_speed) {
  LinearVelocitySample sample;
  sample.stamp = stamp;
  sample.v_base = Eigen::Vector3d(forward_speed, 0.0, 0.0);
  return sample;
}

TEST(TwistCombiner, InterpolatesTheWheelVelocityAtEachGyroStamp) {
  TwistCombiner combiner(TwistCombinerOptions{});
  for (int k = 0; k <= 3; ++k) combiner.addLinearVelocity(wheel(0.1 * k, 1.0 + k));
  combiner.addAngularVelocity(gyro(0.05));
  combiner.addAngularVelocity(gyro(0.1));
  combiner.addAngularVelocity(gyro(0.275));
  const std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 3u);
  EXPECT_DOUBLE_EQ(twists[0].stamp, 0.05);
  EXPECT_NEAR(twists[0].v_imu.x(), 1.5, 1e-12);
  EXPECT_NEAR(twists[1].v_imu.x(), 2.0, 1e-12);
  EXPECT_NEAR(twists[2].v_imu.x(), 3.75, 1e-12);
  EXPECT_EQ(combiner.counters().velocity_held, 0u);
  EXPECT_TRUE(combiner.takeReady().empty());
}

TEST(TwistCombiner, WaitsInMessageTimeForALaterWheelSampleThenHoldsTheLastOne) {
  TwistCombinerOptions options;
  options.max_velocity_wait = 0.2;
  TwistCombiner combiner(options);
  combiner.addLinearVelocity(wheel(0.0, 1.0));
  combiner.addLinearVelocity(wheel(0.1, 2.0));
  combiner.addAngularVelocity(gyro(0.15));
  EXPECT_TRUE(combiner.takeReady().empty()) << "must wait for a wheel sample at or after 0.15";
  combiner.addAngularVelocity(gyro(0.3));  // 0.15 s ahead: still within the wait
  EXPECT_TRUE(combiner.takeReady().empty());
  combiner.addAngularVelocity(gyro(0.36));  // 0.21 s ahead of 0.15: the last velocity is held
  std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 1u);
  EXPECT_DOUBLE_EQ(twists[0].stamp, 0.15);
  EXPECT_DOUBLE_EQ(twists[0].v_imu.x(), 2.0);
  EXPECT_EQ(combiner.counters().velocity_held, 1u);
  // The wheel sample arrives late: the twists still waiting interpolate with it.
  combiner.addLinearVelocity(wheel(0.4, 5.0));
  twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 2u);
  EXPECT_NEAR(twists[0].v_imu.x(), 2.0 + 3.0 * (0.3 - 0.1) / 0.3, 1e-12);
  EXPECT_NEAR(twists[1].v_imu.x(), 2.0 + 3.0 * (0.36 - 0.1) / 0.3, 1e-12);
}

// Played at 10x: the gyro runs 0.3 s of message time (0.03 s of wall time) ahead of a wheel stream
// that is only late. The twist waits for it; once the wheel stream stops, the last velocity is
// held after max_velocity_wait in both clocks.
TEST(TwistCombiner, ALateWheelStreamIsWaitedForInWallTimeToo) {
  TwistCombinerOptions options;
  options.max_velocity_wait = 0.2;
  TwistCombiner combiner(options);
  combiner.addLinearVelocity(wheel(0.0, 1.0), nullptr, 10.0);
  combiner.addLinearVelocity(wheel(0.1, 2.0), nullptr, 10.01);
  combiner.addAngularVelocity(gyro(0.15), nullptr, 10.015);
  combiner.addAngularVelocity(gyro(0.45), nullptr, 10.045);  // 0.3 s of message time ahead
  EXPECT_TRUE(combiner.takeReady().empty()) << "message time alone would hold 2.0 m/s";
  combiner.addLinearVelocity(wheel(0.2, 3.0), nullptr, 10.05);
  std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 1u);
  EXPECT_NEAR(twists[0].v_imu.x(), 2.5, 1e-12);
  EXPECT_EQ(combiner.counters().velocity_held, 0u);
  // The wheel stream stops: 0.45 waits until it has waited 0.2 s of wall time (and the gyro is
  // 0.2 s of message time past it).
  combiner.addAngularVelocity(gyro(0.7), nullptr, 10.07);
  combiner.releaseWaiting(10.2);
  EXPECT_TRUE(combiner.takeReady().empty());
  combiner.releaseWaiting(10.3);
  twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 1u);
  EXPECT_DOUBLE_EQ(twists[0].stamp, 0.45);
  EXPECT_DOUBLE_EQ(twists[0].v_imu.x(), 3.0);
  EXPECT_EQ(combiner.counters().velocity_held, 1u);
}

TEST(TwistCombiner, DropsTwistsWithoutAWheelSampleNearEnough) {
  TwistCombinerOptions options;
  options.max_velocity_wait = 0.125;  // binary fractions: the comparisons below are exact
  options.max_velocity_age = 0.5;
  TwistCombiner combiner(options);
  // No wheel sample yet: 0 and 0.0625 are dropped once the gyro is 0.125 s past them.
  for (int k = 0; k < 5; ++k) combiner.addAngularVelocity(gyro(0.0625 * k));
  EXPECT_TRUE(combiner.takeReady().empty());
  EXPECT_EQ(combiner.counters().dropped_no_velocity, 2u);
  // The first wheel sample (0.25) serves 0.125 and 0.1875 (held back) and 0.25 (exact).
  combiner.addLinearVelocity(wheel(0.25, 1.0));
  EXPECT_EQ(combiner.takeReady().size(), 3u);
  EXPECT_EQ(combiner.counters().velocity_held, 2u);
  // The wheel stream stops: held up to 0.5 s after its last sample (0.3125 ... 0.75), dropped
  // beyond (0.8125 ... 1.3125), and the last three still wait (within 0.125 s of 1.5).
  for (int k = 0; k < 20; ++k) combiner.addAngularVelocity(gyro(0.3125 + 0.0625 * k));
  const std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 8u);
  EXPECT_EQ(twists.back().stamp, 0.75);
  EXPECT_EQ(combiner.counters().twists, 11u);
  EXPECT_EQ(combiner.counters().velocity_held, 10u);
  EXPECT_EQ(combiner.counters().dropped_no_velocity, 11u);
  EXPECT_EQ(combiner.counters().angular_received, 25u);
}

TEST(TwistCombiner, TheSameInputsGiveTheSameTwistsWhateverTheirArrivalOrder) {
  std::vector<AngularVelocitySample> gyros;
  std::vector<LinearVelocitySample> wheels;
  for (int k = 0; k < 50; ++k) {
    gyros.push_back(gyro(0.01 * k + 0.003, Eigen::Vector3d(0.0, 0.0, std::sin(0.1 * k))));
  }
  for (int k = 0; k < 6; ++k) wheels.push_back(wheel(0.1 * k, 5.0 + std::cos(k)));
  TwistCombinerOptions options;
  options.max_velocity_wait = 1.0;
  TwistCombiner gyro_first(options), wheel_first(options), interleaved(options);
  for (const auto& g : gyros) gyro_first.addAngularVelocity(g);
  for (const auto& w : wheels) gyro_first.addLinearVelocity(w);
  for (const auto& w : wheels) wheel_first.addLinearVelocity(w);
  for (const auto& g : gyros) wheel_first.addAngularVelocity(g);
  for (int k = 0; k < 50; ++k) {
    if (k % 10 == 0) interleaved.addLinearVelocity(wheels[k / 10]);
    interleaved.addAngularVelocity(gyros[k]);
  }
  interleaved.addLinearVelocity(wheels[5]);
  const std::vector<TwistData> a = gyro_first.takeReady(), b = wheel_first.takeReady(),
                               c = interleaved.takeReady();
  ASSERT_EQ(a.size(), 50u);  // every gyro stamp (0.003 ... 0.493) lies before the last wheel's
  ASSERT_EQ(b.size(), a.size());
  ASSERT_EQ(c.size(), a.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].stamp, b[i].stamp);
    EXPECT_EQ(a[i].v_imu, b[i].v_imu);
    EXPECT_EQ(a[i].v_imu, c[i].v_imu);
    EXPECT_EQ(a[i].w_imu, c[i].w_imu);
  }
}

TEST(TwistCombiner, AveragesGyroSamplesIntoOneTwistStampedAtTheLast) {
  TwistCombinerOptions options;
  options.imu_samples_per_twist = 4;
  TwistCombiner combiner(options);
  combiner.addLinearVelocity(wheel(0.0, 1.0));
  combiner.addLinearVelocity(wheel(1.0, 1.0));
  for (int k = 1; k <= 8; ++k) {
    AngularVelocitySample sample = gyro(0.01 * k, Eigen::Vector3d(0.0, 0.0, k));
    sample.covariance = 4e-4 * Eigen::Matrix3d::Identity();
    combiner.addAngularVelocity(sample);
  }
  const std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 2u);
  EXPECT_DOUBLE_EQ(twists[0].stamp, 0.04);
  EXPECT_DOUBLE_EQ(twists[0].w_imu.z(), 2.5);
  EXPECT_DOUBLE_EQ(twists[1].w_imu.z(), 6.5);
  // The wheel gave no covariance: none is claimed.
  EXPECT_FALSE(twists[0].hasCovariance());
}

TEST(TwistCombiner, EstimatesEachStreamsNoiseAndKeepsItsDensityAtTheTwistRate) {
  // A 100 Hz gyro and a 20 Hz wheel odometry of white noise, no message covariance: each twist
  // carries the wheel's density over its own period (5 x the per-sample variance), not the
  // near-zero noise that interpolated velocities would show.
  const double sigma_v = 0.2, sigma_w = 0.01;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  TwistCombiner combiner(TwistCombinerOptions{});
  std::vector<TwistData> twists;
  for (int k = 0; k <= 2000; ++k) {
    const double t = 0.01 * k;
    if (k % 5 == 0) {
      LinearVelocitySample wheel_sample = wheel(t, 8.0);
      for (int i = 0; i < 3; ++i) wheel_sample.v_base(i) += sigma_v * normal(rng);
      combiner.addLinearVelocity(wheel_sample);
    }
    AngularVelocitySample gyro_sample = gyro(t, Eigen::Vector3d(0.0, 0.0, 0.1));
    for (int i = 0; i < 3; ++i) gyro_sample.w_imu(i) += sigma_w * normal(rng);
    combiner.addAngularVelocity(gyro_sample);
    for (const TwistData& twist : combiner.takeReady()) twists.push_back(twist);
  }
  ASSERT_GT(twists.size(), 1900u);
  EXPECT_FALSE(twists.front().hasCovariance()) << "no noise estimate before a few samples";
  const Matrix6d& covariance = twists.back().covariance;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(covariance(i, i), 5.0 * sigma_v * sigma_v, 0.25 * 5.0 * sigma_v * sigma_v) << i;
    EXPECT_NEAR(covariance(3 + i, 3 + i), sigma_w * sigma_w, 0.25 * sigma_w * sigma_w) << i;
  }
}

/// Velocity of the IMU origin in IMU axes for a base moving with body twist (v_base, w_base),
/// by differencing the IMU pose over a short step.
Eigen::Vector3d imuVelocityByDifference(const Eigen::Isometry3d& imu_T_base,
                                        const Eigen::Vector3d& v_base,
                                        const Eigen::Vector3d& w_base) {
  const double dt = 1e-6;
  Vector6d xi;
  xi << v_base * dt, w_base * dt;
  const Eigen::Isometry3d base_T_imu = imu_T_base.inverse();
  const Eigen::Isometry3d world_T_imu0 = base_T_imu;  // world = base at time 0
  const Eigen::Isometry3d world_T_imu1 = Eigen::Isometry3d(se3::exp(xi)) * base_T_imu;
  return world_T_imu0.linear().transpose() *
         (world_T_imu1.translation() - world_T_imu0.translation()) / dt;
}

TEST(TwistCombiner, MovesTheWheelVelocityToTheImuOriginAsARigidBody) {
  LinearVelocitySample sample = wheel(0.0, 0.0);
  sample.v_base = Eigen::Vector3d(7.0, 0.2, -0.1);
  Vector6d pose;
  pose << 0.4, -0.3, 1.1, 0.2, -0.5, 1.3;
  sample.imu_T_base = Eigen::Isometry3d(se3::exp(pose));
  const Eigen::Vector3d w_imu(0.1, -0.2, 0.6);
  TwistCombiner combiner(TwistCombinerOptions{});
  combiner.addLinearVelocity(sample);
  combiner.addAngularVelocity(gyro(0.0, w_imu));
  const std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 1u);
  const Eigen::Vector3d w_base = sample.imu_T_base.linear().transpose() * w_imu;
  const Eigen::Vector3d expected =
      imuVelocityByDifference(sample.imu_T_base, sample.v_base, w_base);
  EXPECT_LT((twists[0].v_imu - expected).norm(), 1e-5)
      << twists[0].v_imu.transpose() << " vs " << expected.transpose();
  EXPECT_EQ(twists[0].w_imu, w_imu);
}

TEST(TwistCombiner, CovarianceIsTheJacobianOfTheLeverArmAgainstFiniteDifferences) {
  LinearVelocitySample sample = wheel(0.0, 3.0);
  Vector6d pose;
  pose << 0.4, -0.3, 1.1, 0.2, -0.5, 1.3;
  sample.imu_T_base = Eigen::Isometry3d(se3::exp(pose));
  Eigen::Matrix3d a;
  a << 0.3, 0.01, 0.0, 0.02, 0.1, 0.0, 0.0, 0.03, 0.2;
  sample.covariance = a * a.transpose();
  AngularVelocitySample g = gyro(0.0, Eigen::Vector3d(0.01, 0.02, 0.3));
  g.covariance = 1e-4 * (Eigen::Matrix3d() << 2, 0.3, 0, 0.3, 1, 0.1, 0, 0.1, 3).finished();

  auto combined = [&](const Eigen::Vector3d& dv, const Eigen::Vector3d& dw) {
    LinearVelocitySample s = sample;
    s.v_base += dv;
    AngularVelocitySample gg = g;
    gg.w_imu += dw;
    TwistCombiner combiner(TwistCombinerOptions{});
    combiner.addLinearVelocity(s);
    combiner.addAngularVelocity(gg);
    const TwistData twist = combiner.takeReady().at(0);
    Vector6d out;
    out << twist.v_imu, twist.w_imu;
    return std::make_pair(out, twist.covariance);
  };
  const auto [nominal, covariance] = combined(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  Eigen::Matrix<double, 6, 6> J;
  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    Eigen::Vector3d dv = Eigen::Vector3d::Zero(), dw = Eigen::Vector3d::Zero();
    (i < 3 ? dv : dw)(i % 3) = h;
    J.col(i) = (combined(dv, dw).first - nominal) / h;
  }
  Eigen::Matrix<double, 6, 6> input = Eigen::Matrix<double, 6, 6>::Zero();
  input.topLeftCorner<3, 3>() = sample.covariance;
  input.bottomRightCorner<3, 3>() = g.covariance;
  const Eigen::Matrix<double, 6, 6> expected = J * input * J.transpose();
  EXPECT_LT((covariance - expected).norm(), 1e-6 * expected.norm()) << covariance << "\n\n"
                                                                    << expected;
}

TEST(TwistCombiner, RefusesNonFiniteAndOutOfOrderSamplesAndGoesOn) {
  TwistCombiner combiner(TwistCombinerOptions{});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::string why;
  combiner.addLinearVelocity(wheel(0.0, 1.0));
  combiner.addLinearVelocity(wheel(1.0, 1.0));
  EXPECT_FALSE(combiner.addAngularVelocity(gyro(0.1, Eigen::Vector3d(nan, 0, 0)), &why));
  EXPECT_NE(why.find("not finite"), std::string::npos);
  EXPECT_FALSE(combiner.addLinearVelocity(wheel(2.0, nan), &why));
  EXPECT_TRUE(combiner.addAngularVelocity(gyro(0.2)));
  EXPECT_FALSE(combiner.addAngularVelocity(gyro(0.2), &why));
  EXPECT_NE(why.find("not after"), std::string::npos);
  EXPECT_FALSE(combiner.addLinearVelocity(wheel(0.5, 1.0)));
  EXPECT_TRUE(combiner.addAngularVelocity(gyro(0.3)));
  const std::vector<TwistData> twists = combiner.takeReady();
  ASSERT_EQ(twists.size(), 2u);
  for (const TwistData& twist : twists) {
    EXPECT_TRUE(twist.v_imu.allFinite());
    EXPECT_TRUE(twist.w_imu.allFinite());
  }
  EXPECT_EQ(combiner.counters().rejected_non_finite, 2u);
  EXPECT_EQ(combiner.counters().rejected_not_increasing, 2u);
  // After a reset (time went back) older stamps are taken again.
  combiner.reset();
  combiner.addLinearVelocity(wheel(0.0, 2.0));
  EXPECT_TRUE(combiner.addAngularVelocity(gyro(0.0)));
  ASSERT_EQ(combiner.takeReady().size(), 1u);
}

TEST(TwistCombinerOptions, EveryKeyIsDocumentedInTheShippedFileAndRangeChecked) {
  YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/twist_combiner.yaml");
  for (const OptionKeyList::Key& key : twistCombinerOptionKeys()) {
    EXPECT_TRUE(source.has(key.name)) << key.name << " is not in config/twist_combiner.yaml";
  }
  TwistCombinerOptions options;
  std::string error;
  EXPECT_TRUE(parseTwistCombinerOptions(source, &options, &error)) << error;
  EXPECT_NE(describeTwistCombinerOptions(options).find("imu_samples_per_twist"), std::string::npos);
  for (const char* bad :
       {"combiner: {imu_samples_per_twist: 0}\n", "combiner: {max_velocity_wait: -0.1}\n",
        "combiner: {max_velocity_age: 0}\n"}) {
    error.clear();
    TwistCombinerOptions unchanged;
    EXPECT_FALSE(
        parseTwistCombinerOptions(YamlParameterSource::fromString(bad), &unchanged, &error))
        << bad;
    EXPECT_NE(error.find("combiner/"), std::string::npos) << error;
    EXPECT_EQ(unchanged.imu_samples_per_twist, 1);
  }
}

}  // namespace
}  // namespace ekf_vislam
