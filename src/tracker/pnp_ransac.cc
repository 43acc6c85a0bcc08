#include "ekf_vislam/tracker/pnp_ransac.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <opencv2/calib3d.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>

namespace ekf_vislam {

namespace {

constexpr int kSampleSize = 3;
constexpr int kLocalRounds = 3;

struct Motion {
  Eigen::Matrix3d cur_R_prev;
  Eigen::Vector3d cur_t_prev;
};

// The rotation by |axis_angle| about its direction. (se3::expSO3 is the same map, but its
// rounding differs in the last bits, and RANSAC's inlier decisions at the threshold follow them.)
Eigen::Matrix3d rotationOf(const Eigen::Vector3d& axis_angle) {
  const double angle = axis_angle.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, axis_angle / angle).toRotationMatrix()
                   : Eigen::Matrix3d::Identity();
}

Motion motionOf(const cv::Mat& rvec, const cv::Mat& tvec) {
  const cv::Vec3d r(rvec);
  const cv::Vec3d t(tvec);
  Motion motion;
  motion.cur_R_prev = rotationOf(Eigen::Vector3d(r[0], r[1], r[2]));
  motion.cur_t_prev = Eigen::Vector3d(t[0], t[1], t[2]);
  return motion;
}

// The motion puts the point in front of the camera, within the threshold of its pixel.
bool reprojectsWithin(const Motion& motion, const Eigen::Vector3d& point,
                      const Eigen::Vector2d& pixel, const StereoCalibration& c,
                      double threshold_sq) {
  const Eigen::Vector3d q = motion.cur_R_prev * point + motion.cur_t_prev;
  return q.z() > 0 && (project(c, q) - pixel).squaredNorm() <= threshold_sq;
}

// Counts the matches the motion explains, and stops once the count can no longer exceed
// `to_beat`.
int countInliers(const Motion& motion, const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Vector2d>& pixels, const StereoCalibration& c,
                 double threshold_sq, int to_beat) {
  const int n = static_cast<int>(points.size());
  int count = 0;
  for (int i = 0; i < n && count + (n - i) > to_beat; ++i) {
    count += reprojectsWithin(motion, points[i], pixels[i], c, threshold_sq);
  }
  return count;
}

std::vector<int> inliersOf(const Motion& motion, const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector2d>& pixels, const StereoCalibration& c,
                           double threshold_sq) {
  std::vector<int> inliers;
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    if (reprojectsWithin(motion, points[i], pixels[i], c, threshold_sq)) inliers.push_back(i);
  }
  return inliers;
}

// Gauss-Newton steps on the reprojection error of the given matches, the motion perturbed as
// R <- exp(dtheta) R, t <- exp(dtheta) t + dt.
Motion refineOn(Motion motion, const std::vector<int>& matches,
                const std::vector<Eigen::Vector3d>& points,
                const std::vector<Eigen::Vector2d>& pixels, const StereoCalibration& c) {
  constexpr int kSteps = 3;
  for (int step = 0; step < kSteps; ++step) {
    Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> gradient = Eigen::Matrix<double, 6, 1>::Zero();
    for (const int i : matches) {
      const Eigen::Vector3d q = motion.cur_R_prev * points[i] + motion.cur_t_prev;
      if (q.z() <= 0) continue;
      const Eigen::Matrix<double, 2, 6> jacobian = reprojectionJacobian(c, q);
      const Eigen::Vector2d residual = project(c, q) - pixels[i];
      normal.noalias() += jacobian.transpose() * jacobian;
      gradient.noalias() += jacobian.transpose() * residual;
    }
    const Eigen::Matrix<double, 6, 1> delta = -normal.ldlt().solve(gradient);
    if (!delta.allFinite()) break;
    const Eigen::Matrix3d turn = rotationOf(delta.head<3>());
    motion.cur_R_prev = turn * motion.cur_R_prev;
    motion.cur_t_prev = turn * motion.cur_t_prev + delta.tail<3>();
  }
  return motion;
}

}  // namespace

Eigen::Matrix<double, 2, 6> reprojectionJacobian(const StereoCalibration& calibration,
                                                 const Eigen::Vector3d& q) {
  const double inv_z = 1.0 / q.z();
  Eigen::Matrix<double, 2, 3> d_pixel_d_q;
  d_pixel_d_q << calibration.fx * inv_z, 0, -calibration.fx * q.x() * inv_z * inv_z, 0,
      calibration.fy * inv_z, -calibration.fy * q.y() * inv_z * inv_z;
  // q <- exp(dtheta) q + dt = q - q^ dtheta + dt to first order.
  Eigen::Matrix<double, 2, 6> jacobian;
  jacobian << -d_pixel_d_q * se3::hat(q), d_pixel_d_q;
  return jacobian;
}

int ransacIterationsNeeded(double inlier_ratio, int sample_size, double confidence,
                           int max_iterations) {
  const double all_inliers = std::pow(std::clamp(inlier_ratio, 0.0, 1.0), sample_size);
  if (all_inliers >= 1.0) return std::min(1, max_iterations);
  const double miss = std::log1p(-all_inliers);
  if (!(miss < 0)) return max_iterations;
  const double needed = std::ceil(std::log1p(-confidence) / miss);
  return static_cast<int>(std::clamp(needed, 1.0, static_cast<double>(max_iterations)));
}

PnpRansacResult pnpRansac(const std::vector<cv::Point3f>& points_prev,
                          const std::vector<cv::Point2f>& pixels_cur,
                          const StereoCalibration& calibration, const PnpRansacOptions& options) {
  PnpRansacResult result;
  const int n = static_cast<int>(std::min(points_prev.size(), pixels_cur.size()));
  if (n < kSampleSize + 1) return result;
  std::vector<Eigen::Vector3d> points(n);
  std::vector<Eigen::Vector2d> pixels(n);
  for (int i = 0; i < n; ++i) {
    points[i] = Eigen::Vector3d(points_prev[i].x, points_prev[i].y, points_prev[i].z);
    pixels[i] = Eigen::Vector2d(pixels_cur[i].x, pixels_cur[i].y);
  }
  const cv::Matx33d K = cameraMatrix(calibration);
  const double threshold_sq = options.threshold_px * options.threshold_px;
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<cv::Point3f> sample_points(kSampleSize);
  std::vector<cv::Point2f> sample_pixels(kSampleSize);
  std::vector<cv::Mat> rvecs, tvecs;
  int best_count = kSampleSize;  // a motion must explain more than its own sample
  Motion best{Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()};
  int needed = options.max_iterations;
  for (; result.iterations < needed; ++result.iterations) {
    int index[kSampleSize];
    for (int k = 0; k < kSampleSize; ++k) {
      do {
        index[k] = pick(rng);
      } while (std::find(index, index + k, index[k]) != index + k);
      sample_points[k] = points_prev[index[k]];
      sample_pixels[k] = pixels_cur[index[k]];
    }
    const int solutions = cv::solveP3P(sample_points, sample_pixels, K, cv::noArray(), rvecs, tvecs,
                                       cv::SOLVEPNP_AP3P);
    for (int s = 0; s < solutions; ++s) {
      const Motion motion = motionOf(rvecs[s], tvecs[s]);
      const int count = countInliers(motion, points, pixels, calibration, threshold_sq, best_count);
      if (count <= best_count) continue;
      // A better sample: fit the motion to all its inliers as long as that finds more (the
      // sample's own noise costs inliers at a threshold of a pixel or two).
      best = motion;
      std::vector<int> inliers = inliersOf(best, points, pixels, calibration, threshold_sq);
      for (int round = 0; round < kLocalRounds; ++round) {
        const Motion fitted = refineOn(best, inliers, points, pixels, calibration);
        std::vector<int> fitted_inliers =
            inliersOf(fitted, points, pixels, calibration, threshold_sq);
        if (fitted_inliers.size() <= inliers.size()) break;
        best = fitted;
        inliers = std::move(fitted_inliers);
      }
      best_count = static_cast<int>(inliers.size());
      result.inliers = std::move(inliers);
      result.found = true;
      needed = ransacIterationsNeeded(static_cast<double>(best_count) / n, kSampleSize,
                                      options.confidence, options.max_iterations);
    }
  }
  result.cur_R_prev = best.cur_R_prev;
  result.cur_t_prev = best.cur_t_prev;
  return result;
}

}  // namespace ekf_vislam
