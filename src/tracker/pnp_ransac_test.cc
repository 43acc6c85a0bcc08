#include "ekf_vislam/tracker/pnp_ransac.h"

#include "ekf_vislam/tracker/rectified_stereo.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <random>
#include <set>

namespace ekf_vislam {
namespace {

// A KITTI-like rectified camera: fx, fy, cx, cy (px), baseline (m).
const StereoCalibration kCamera = rectifiedPair(718.0, 718.0, 607.0, 185.0, 0.54);

struct Matches {
  std::vector<cv::Point3f> points_prev;
  std::vector<cv::Point2f> pixels_cur;
  std::set<int> outliers;
  Eigen::Matrix3d cur_R_prev;
  Eigen::Vector3d cur_t_prev;
};

// n points 5-60 m ahead seen after a turn and a step forward, with Gaussian pixel noise; a
// fraction of them moved 3-30 px (wrong matches).
Matches makeMatches(int n, double outlier_fraction, double noise_px, uint32_t seed) {
  const StereoCalibration& c = kCamera;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  Matches m;
  m.cur_R_prev = Eigen::AngleAxisd(0.04, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                 Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()).toRotationMatrix();
  m.cur_t_prev = Eigen::Vector3d(0.05, -0.02, -1.2);
  while (static_cast<int>(m.points_prev.size()) < n) {
    const double z = 5.0 + 55.0 * unit(rng);
    const Eigen::Vector3d p_prev =
        normalized(c, cv::Point2f(1226 * unit(rng), 370 * unit(rng))) * z;
    const Eigen::Vector3d p_cur = m.cur_R_prev * p_prev + m.cur_t_prev;
    if (p_cur.z() < 1.0) continue;
    Eigen::Vector2d pixel = project(c, p_cur) + Eigen::Vector2d(noise(rng), noise(rng));
    if (unit(rng) < outlier_fraction) {
      const double angle = 2 * M_PI * unit(rng);
      pixel += (3.0 + 27.0 * unit(rng)) * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      m.outliers.insert(static_cast<int>(m.points_prev.size()));
    }
    m.points_prev.emplace_back(p_prev.x(), p_prev.y(), p_prev.z());
    m.pixels_cur.emplace_back(pixel.x(), pixel.y());
  }
  return m;
}

TEST(PnpRansac, FindsTheMotionAndRefusesTheWrongMatches) {
  for (const double outlier_fraction : {0.0, 0.3, 0.55}) {
    const Matches m = makeMatches(150, outlier_fraction, 0.2, 7);
    const PnpRansacResult result = pnpRansac(m.points_prev, m.pixels_cur, kCamera, {});
    ASSERT_TRUE(result.found) << outlier_fraction;
    const Eigen::AngleAxisd rotation_error(result.cur_R_prev * m.cur_R_prev.transpose());
    EXPECT_LT(rotation_error.angle(), 2e-3) << outlier_fraction;
    EXPECT_LT((result.cur_t_prev - m.cur_t_prev).norm(), 0.05) << outlier_fraction;
    int wrong_kept = 0;
    for (const int i : result.inliers) wrong_kept += m.outliers.count(i);
    EXPECT_EQ(wrong_kept, 0) << outlier_fraction;
    const int true_matches = 150 - static_cast<int>(m.outliers.size());
    EXPECT_GE(static_cast<int>(result.inliers.size()), 0.97 * true_matches) << outlier_fraction;
    // Samples adapt to the ratio found: few for clean matches, never more than allowed.
    EXPECT_LE(result.iterations, 200);
    if (outlier_fraction == 0.0) {
      EXPECT_LE(result.iterations, 8);
    }
  }
}

TEST(PnpRansac, KeepsTheInliersOpenCvsRansacKeeps) {
  const StereoCalibration& c = kCamera;
  const cv::Matx33d K = cameraMatrix(c);
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const Matches m = makeMatches(120, 0.4, 0.3, seed);
    const PnpRansacResult ours = pnpRansac(m.points_prev, m.pixels_cur, c, {});
    cv::Mat rvec, tvec;
    std::vector<int> theirs;
    ASSERT_TRUE(cv::solvePnPRansac(m.points_prev, m.pixels_cur, K, cv::noArray(), rvec, tvec, false,
                                   200, 1.0, 0.99, theirs, cv::SOLVEPNP_AP3P));
    std::vector<int> both;
    std::set_intersection(ours.inliers.begin(), ours.inliers.end(), theirs.begin(), theirs.end(),
                          std::back_inserter(both));
    const size_t larger = std::max(ours.inliers.size(), theirs.size());
    EXPECT_GE(both.size(), 0.93 * larger)
        << "seed " << seed << ": " << ours.inliers.size() << " inliers against OpenCV's "
        << theirs.size() << ", " << 120 - m.outliers.size() << " true matches";
  }
}

TEST(PnpRansac, TheSameInputGivesTheSameResult) {
  const Matches m = makeMatches(100, 0.5, 0.3, 3);
  const PnpRansacResult a = pnpRansac(m.points_prev, m.pixels_cur, kCamera, {});
  const PnpRansacResult b = pnpRansac(m.points_prev, m.pixels_cur, kCamera, {});
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.cur_R_prev, b.cur_R_prev);
  EXPECT_EQ(a.cur_t_prev, b.cur_t_prev);
}

TEST(PnpRansac, MatchesWithoutACommonMotionExplainFew) {
  Matches m = makeMatches(100, 0.0, 0.3, 4);
  std::mt19937 rng(5);
  std::shuffle(m.pixels_cur.begin(), m.pixels_cur.end(), rng);
  const PnpRansacResult result = pnpRansac(m.points_prev, m.pixels_cur, kCamera, {});
  EXPECT_LT(result.inliers.size(), 10u);  // motion_check needs min_points / 2 = 6 and more
  EXPECT_EQ(result.iterations, 200);
  EXPECT_FALSE(pnpRansac(std::vector<cv::Point3f>(m.points_prev.begin(), m.points_prev.begin() + 3),
                         m.pixels_cur, kCamera, {})
                   .found);
}

TEST(PnpRansac, RefitJacobianMatchesFiniteDifferences) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, -0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.4, -0.1, -1.5);
  const Eigen::Vector3d p_prev(2.0, -1.0, 12.0);
  const Eigen::Vector3d q = R * p_prev + t;
  const Eigen::Matrix<double, 2, 6> analytic = reprojectionJacobian(kCamera, q);
  constexpr double kStep = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
    delta(k) = kStep;
    const Eigen::Vector3d dtheta = delta.head<3>();
    const Eigen::Matrix3d turn =
        dtheta.norm() > 0 ? Eigen::AngleAxisd(dtheta.norm(), dtheta.normalized()).toRotationMatrix()
                          : Eigen::Matrix3d::Identity();
    const Eigen::Vector3d q_moved = turn * R * p_prev + turn * t + delta.tail<3>();
    const Eigen::Vector2d numeric = (project(kCamera, q_moved) - project(kCamera, q)) / kStep;
    EXPECT_LT((numeric - analytic.col(k)).norm(), 1e-4 * (1.0 + analytic.col(k).norm())) << k;
  }
}

TEST(PnpRansac, IterationsFollowTheInlierRatio) {
  EXPECT_EQ(ransacIterationsNeeded(1.0, 3, 0.99, 200), 1);
  // 1 - (1 - 0.5^3)^35 = 0.9906 >= 0.99 > 1 - (1 - 0.5^3)^34 = 0.9893.
  EXPECT_EQ(ransacIterationsNeeded(0.5, 3, 0.99, 200), 35);
  EXPECT_EQ(ransacIterationsNeeded(0.2, 3, 0.99, 200), 200);
  EXPECT_EQ(ransacIterationsNeeded(0.0, 3, 0.99, 200), 200);
}

}  // namespace
}  // namespace ekf_vislam
