#include "ekf_vislam/tracker/disparity_offset_fit.h"

#include "ekf_vislam/tracker/pnp_ransac.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace ekf_vislam {
namespace {

// A KITTI-like rectified camera: fx, fy, cx, cy (px), baseline (m).
const StereoCalibration kCamera = rectifiedPair(718.0, 718.0, 607.0, 185.0, 0.54);

struct Pair {
  std::vector<DisparityOffsetMatch> matches;
  PnpRansacResult ransac;  // the motion fitted with the measured disparities as they are
};

// n points 4-80 m ahead, seen again after the motion; every measured disparity is the true one
// plus `offset_px` (and 0.1 px of noise), the current pixels carry 0.2 px of noise, and a fifth of
// the matches are wrong by 3-30 px. The RANSAC's motion reads the disparities as measured.
Pair makePair(double offset_px, const Eigen::Matrix3d& cur_R_prev,
              const Eigen::Vector3d& cur_t_prev, uint32_t seed) {
  constexpr int kMatches = 250;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  Pair pair;
  std::vector<cv::Point3f> points_measured;
  std::vector<cv::Point2f> pixels_cur;
  while (static_cast<int>(pair.matches.size()) < kMatches) {
    const double z = 4.0 + 76.0 * unit(rng);
    const cv::Point2f left(1226 * unit(rng), 370 * unit(rng));
    const Eigen::Vector3d p_cur = cur_R_prev * (normalized(kCamera, left) * z) + cur_t_prev;
    if (p_cur.z() < 1.0) continue;
    Eigen::Vector2d pixel = project(kCamera, p_cur) + 0.2 * Eigen::Vector2d(noise(rng), noise(rng));
    if (unit(rng) < 0.2) {
      const double angle = 2 * M_PI * unit(rng);
      pixel += (3.0 + 27.0 * unit(rng)) * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    const double measured = disparityAtDepth(kCamera, z) + offset_px + 0.1 * noise(rng);
    if (measured <= 0.5) continue;
    const cv::Point2f cur(static_cast<float>(pixel.x()), static_cast<float>(pixel.y()));
    pair.matches.push_back({left, static_cast<float>(measured), cur});
    const Eigen::Vector3d p = *triangulate(kCamera, left, measured);
    points_measured.emplace_back(p.x(), p.y(), p.z());
    pixels_cur.push_back(cur);
  }
  pair.ransac = pnpRansac(points_measured, pixels_cur, kCamera, {});
  return pair;
}

const Eigen::Matrix3d kTurn = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitY()).toRotationMatrix();

TEST(DisparityOffsetFit, FindsTheOffsetOfAForwardPair) {
  // 1.0 m and 2.5 m forward (KITTI's city and highway clips at 10 Hz).
  for (const double forward : {1.0, 2.5}) {
    for (const double offset : {-1.5, -0.5, 0.0, 0.8}) {
      const Pair pair = makePair(offset, kTurn, Eigen::Vector3d(0.02, 0.01, -forward), 3);
      ASSERT_TRUE(pair.ransac.found);
      const DisparityOffsetFit fit = fitDisparityOffset(pair.matches, pair.ransac.cur_R_prev,
                                                        pair.ransac.cur_t_prev, kCamera, 1.0);
      ASSERT_TRUE(fit.fitted) << forward << " " << offset;
      EXPECT_NEAR(fit.offset_px, offset, 0.1) << forward;
      EXPECT_NEAR(fit.offset_px, offset, 4 * fit.offset_sigma_px) << forward;
      EXPECT_LT(fit.offset_sigma_px, 0.1) << forward << " " << offset;
      EXPECT_NEAR(fit.cur_t_prev.z(), -forward, 0.02 * forward);
      // About four fifths of the matches are right; the fit finds them all again, where the
      // RANSAC, reading the disparities as measured, keeps fewer once the offset is large.
      EXPECT_GT(fit.inliers, 0.75 * pair.matches.size()) << forward << " " << offset;
      if (forward > 2 && std::abs(offset) >= 1.5) {
        EXPECT_LT(pair.ransac.inliers.size(), 0.9 * fit.inliers) << offset;
      }
    }
  }
}

TEST(DisparityOffsetFit, CannotTellTheOffsetWithoutTranslation) {
  // A turn in place moves every point alike whatever its depth: the offset's error is large.
  const Pair pair = makePair(-1.0, kTurn, Eigen::Vector3d::Zero(), 5);
  ASSERT_TRUE(pair.ransac.found);
  const DisparityOffsetFit fit = fitDisparityOffset(pair.matches, pair.ransac.cur_R_prev,
                                                    pair.ransac.cur_t_prev, kCamera, 1.0);
  if (fit.fitted) {
    EXPECT_GT(fit.offset_sigma_px, 1.0);
  }
}

TEST(DisparityOffsetFit, NeedsEnoughMatches) {
  Pair pair = makePair(0.0, kTurn, Eigen::Vector3d(0, 0, -1), 9);
  pair.matches.resize(20);
  EXPECT_FALSE(
      fitDisparityOffset(pair.matches, pair.ransac.cur_R_prev, pair.ransac.cur_t_prev, kCamera, 1.0)
          .fitted);
}

}  // namespace
}  // namespace ekf_vislam
