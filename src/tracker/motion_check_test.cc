#include "ekf_vislam/tracker/motion_check.h"

#include "ekf_vislam/tracker/rectified_stereo.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <random>
#include <vector>

namespace ekf_vislam {
namespace {

const StereoCalibration kCamera = rectifiedPair(400, 400, 320, 120, 0.5);

// Matches of random points 4-20 m ahead (far ones 70-90 m, beyond ransac/max_pnp_depth_m)
// under the camera motion p_cur = R p_prev + t, exact.
struct Matches {
  std::vector<cv::Point3f> prev_points;
  std::vector<cv::Point2f> prev, cur;
};

Matches exactMatches(int near, int far, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1, 1);
  Matches m;
  for (int i = 0; i < near + far; ++i) {
    const Eigen::Vector3d p =
        i < near ? Eigen::Vector3d(6 * uniform(rng), 2 * uniform(rng), 12 + 8 * uniform(rng))
                 : Eigen::Vector3d(30 * uniform(rng), 8 * uniform(rng), 80 + 10 * uniform(rng));
    const Eigen::Vector3d q = R * p + t;
    const Eigen::Vector2d prev = project(kCamera, p), cur = project(kCamera, q);
    m.prev_points.emplace_back(p.x(), p.y(), p.z());
    m.prev.emplace_back(prev.x(), prev.y());
    m.cur.emplace_back(cur.x(), cur.y());
  }
  return m;
}

const Eigen::Matrix3d kTurn = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).matrix();
const Eigen::Vector3d kForward(0.05, 0.0, -0.8);

TEST(MotionCheck, RejectsAnInjectedWrongMatch) {
  Matches m = exactMatches(80, 0, kTurn, kForward);
  m.cur[17].x += 3.0f;  // a KLT match that slid 3 px
  m.cur[42].y -= 2.0f;
  for (TemporalOutlierCheck type :
       {TemporalOutlierCheck::kPnp, TemporalOutlierCheck::kFundamental}) {
    TrackerOptions options;
    options.outlier_check = type;
    const MotionCheckResult result =
        checkTemporalMatches(m.prev_points, m.prev, m.cur, kCamera, options);
    ASSERT_TRUE(result.checked);
    EXPECT_EQ(result.inlier[17], 0);
    EXPECT_EQ(result.inlier[42], 0);
    int inliers = 0;
    for (uint8_t in : result.inlier) inliers += in;
    EXPECT_GE(inliers, 76);
    if (type == TemporalOutlierCheck::kPnp) {
      ASSERT_TRUE(result.has_motion);
      EXPECT_LT((result.cur_t_prev - kForward).norm(), 1e-3);
      EXPECT_LT((result.cur_R_prev - kTurn).norm(), 1e-4);
    }
  }
}

TEST(MotionCheck, FarPointsAndPointsWithoutDepthAreHeldToTheEpipolarLine) {
  Matches m = exactMatches(40, 20, kTurn, kForward);
  m.prev_points[3].z = -1.0f;  // no stereo depth
  // A far match slid along its epipolar line (the pixel of a point on its ray at a quarter of
  // its depth) stays; one slid across it goes.
  const int along = 45, across = 50;
  const Eigen::Vector3d p(25.0, 3.0, 85.0);
  const Eigen::Vector2d prev = project(kCamera, p);
  const Eigen::Vector2d slid = project(kCamera, kTurn * (0.25 * p) + kForward);
  ASSERT_GT((slid - project(kCamera, kTurn * p + kForward)).norm(), 4.0);  // threshold 1 px
  m.prev_points[along] = cv::Point3f(25.0f, 3.0f, 85.0f);
  m.prev[along] = cv::Point2f(static_cast<float>(prev.x()), static_cast<float>(prev.y()));
  m.cur[along] = cv::Point2f(static_cast<float>(slid.x()), static_cast<float>(slid.y()));
  m.cur[across].y += 3.0f;
  TrackerOptions options;
  options.outlier_check = TemporalOutlierCheck::kPnp;
  options.max_pnp_depth_m = 60.0;
  const MotionCheckResult result =
      checkTemporalMatches(m.prev_points, m.prev, m.cur, kCamera, options);
  ASSERT_TRUE(result.has_motion);
  EXPECT_EQ(result.inlier[3], 1);
  EXPECT_EQ(result.inlier[along], 1);
  EXPECT_EQ(result.inlier[across], 0);
  int inliers = 0;
  for (uint8_t in : result.inlier) inliers += in;
  EXPECT_EQ(inliers, 59);
}

TEST(MotionCheck, TooFewMatchesOrNoCheckKeepEveryMatch) {
  Matches m = exactMatches(8, 0, kTurn, kForward);
  m.cur[2].x += 5.0f;
  TrackerOptions options;
  options.min_ransac_points = 12;
  for (TemporalOutlierCheck type : {TemporalOutlierCheck::kPnp, TemporalOutlierCheck::kFundamental,
                                    TemporalOutlierCheck::kNone}) {
    options.outlier_check = type;
    const MotionCheckResult result =
        checkTemporalMatches(m.prev_points, m.prev, m.cur, kCamera, options);
    EXPECT_FALSE(result.checked);
    EXPECT_FALSE(result.has_motion);
    EXPECT_EQ(result.inlier, std::vector<uint8_t>(8, 1));
  }
  options.outlier_check = TemporalOutlierCheck::kNone;
  Matches many = exactMatches(40, 0, kTurn, kForward);
  many.cur[2].x += 5.0f;
  EXPECT_EQ(checkTemporalMatches(many.prev_points, many.prev, many.cur, kCamera, options).inlier,
            std::vector<uint8_t>(40, 1));
}

}  // namespace
}  // namespace ekf_vislam
