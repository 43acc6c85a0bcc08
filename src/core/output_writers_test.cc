#include "ekf_vislam/core/output_writers.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace ekf_vislam {
namespace {

TEST(OutputWriters, TumLineHasTimePositionQuaternion) {
  StampedPose pose;
  pose.stamp = 1317386425.5625024;
  pose.world_T_imu.translation() = Eigen::Vector3d(1.5, -2.0, 0.25);
  pose.world_T_imu.linear() =
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::ostringstream out;
  writeTumLine(out, pose);
  std::istringstream in(out.str());
  double v[8];
  for (double& x : v) in >> x;
  EXPECT_NEAR(v[0], pose.stamp, 1e-6);
  EXPECT_DOUBLE_EQ(v[1], 1.5);
  EXPECT_DOUBLE_EQ(v[2], -2.0);
  EXPECT_NEAR(v[6], std::sqrt(0.5), 1e-9);  // qz
  EXPECT_NEAR(v[7], std::sqrt(0.5), 1e-9);  // qw
}

TEST(OutputWriters, LandmarksCsvHeaderAndSigmasOfTheConfirmedOnes) {
  LandmarkEstimate l;
  l.id = 42;
  l.p_world = Eigen::Vector3d(1, 2, 3);
  l.covariance = Eigen::Vector3d(0.04, 0.09, 0.16).asDiagonal();
  l.observations = 7;
  LandmarkEstimate seen_once = l;  // not in the map
  seen_once.id = 43;
  seen_once.observations = 1;
  const std::string path = ::testing::TempDir() + "/landmarks.csv";
  std::string error;
  ASSERT_TRUE(writeLandmarksCsv(path, {l, seen_once}, &error)) << error;
  std::ifstream in(path);
  std::string header, row, more;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(header, "id,x,y,z,sigma_x,sigma_y,sigma_z,observations");
  EXPECT_EQ(row, "42,1,2,3,0.2,0.3,0.4,7");
  EXPECT_FALSE(std::getline(in, more));
  EXPECT_FALSE(writeLandmarksCsv("/nonexistent/dir/x.csv", {l}, &error));
  EXPECT_NE(error.find("/nonexistent/dir/x.csv"), std::string::npos);
}

TEST(OutputWriters, TrajectoryCovarianceRowMajorOneLinePerPose) {
  StampedPose a, b;
  a.stamp = 1317384506.4;
  b.stamp = 1317384506.5;
  Matrix6d covariance_a, covariance_b = Matrix6d::Identity();
  for (int i = 0; i < 36; ++i) covariance_a(i / 6, i % 6) = 0.001 * i;
  const std::string path = ::testing::TempDir() + "/trajectory_covariance.txt";
  std::string error;
  ASSERT_TRUE(writeTrajectoryCovariance(path, {a, b}, {covariance_a, covariance_b}, &error))
      << error;
  std::ifstream in(path);
  std::vector<std::vector<double>> rows;
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    rows.emplace_back();
    for (double v; fields >> v;) rows.back().push_back(v);
  }
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_EQ(rows[0].size(), 37u);
  EXPECT_DOUBLE_EQ(rows[0][0], a.stamp);
  for (int i = 0; i < 36; ++i) EXPECT_DOUBLE_EQ(rows[0][1 + i], 0.001 * i) << i;  // row-major
  EXPECT_DOUBLE_EQ(rows[1][1 + 7], 1.0);                                          // (1, 1)
  EXPECT_DOUBLE_EQ(rows[1][1 + 1], 0.0);
  EXPECT_FALSE(writeTrajectoryCovariance(path, {a, b}, {covariance_a}, &error));
}

TEST(OutputWriters, PercentilesAndJson) {
  ProcessingTimes times;
  for (int i = 1; i <= 100; ++i) times.add(i);
  EXPECT_DOUBLE_EQ(times.percentile(0.5), 50);
  EXPECT_DOUBLE_EQ(times.percentile(0.99), 99);
  EXPECT_DOUBLE_EQ(times.max(), 100);
  EstimatorStats stats;
  stats.increment(Counter::kObsGated, 3);
  stats.increment(Counter::kObservationUpdate, 10);
  RunSummary summary;
  summary.mode = "slam";
  summary.frames = 100;
  summary.wall_s = 0.5;
  summary.data_s = 10.0;
  const std::string json = statsToJson(stats, times, summary);
  EXPECT_NE(json.find("\"observation_gated\": 3"), std::string::npos);
  EXPECT_NE(json.find("\"observations_rejected\": 3"), std::string::npos);
  EXPECT_NE(json.find("\"p99\": 99"), std::string::npos);
  EXPECT_NE(json.find("\"realtime_factor\": 20"), std::string::npos);
}

}  // namespace
}  // namespace ekf_vislam
