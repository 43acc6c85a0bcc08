#include "ekf_vislam/tracker/motion_check.h"

#include "ekf_vislam/core/se3.h"
#include "ekf_vislam/tracker/pnp_ransac.h"
#include "ekf_vislam/tracker/rectified_stereo.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <cmath>

namespace ekf_vislam {

namespace {

MotionCheckResult fundamentalCheck(const std::vector<cv::Point2f>& prev_pixels,
                                   const std::vector<cv::Point2f>& cur_pixels,
                                   const TrackerOptions& options) {
  MotionCheckResult result;
  result.inlier.assign(prev_pixels.size(), 1);
  if (static_cast<int>(prev_pixels.size()) < options.min_ransac_points) return result;
  std::vector<uint8_t> mask;
  const cv::Mat F =
      cv::findFundamentalMat(prev_pixels, cur_pixels, cv::FM_RANSAC, options.ransac_threshold_px,
                             options.ransac_confidence, options.ransac_iterations, mask);
  if (F.empty() || mask.size() != prev_pixels.size()) return result;
  result.inlier = mask;
  result.checked = true;
  return result;
}

// Squared Sampson distance of a match under the essential matrix E (normalized coordinates),
// returned in pixels through the focal length.
double epipolarErrorPx(const Eigen::Matrix3d& E, const cv::Point2f& prev, const cv::Point2f& cur,
                       const StereoCalibration& c) {
  const Eigen::Vector3d x0 = normalized(c, prev);
  const Eigen::Vector3d x1 = normalized(c, cur);
  const Eigen::Vector3d Ex0 = E * x0;
  const Eigen::Vector3d Etx1 = E.transpose() * x1;
  const double numerator = x1.dot(Ex0);
  const double denominator =
      Ex0.x() * Ex0.x() + Ex0.y() * Ex0.y() + Etx1.x() * Etx1.x() + Etx1.y() * Etx1.y();
  if (denominator <= 0) return 0.0;
  return std::abs(numerator) / std::sqrt(denominator) * std::sqrt(c.fx * c.fy);
}

}  // namespace

MotionCheckResult checkTemporalMatches(const std::vector<cv::Point3f>& prev_points,
                                       const std::vector<cv::Point2f>& prev_pixels,
                                       const std::vector<cv::Point2f>& cur_pixels,
                                       const StereoCalibration& calibration,
                                       const TrackerOptions& options) {
  const size_t n = cur_pixels.size();
  if (options.outlier_check == TemporalOutlierCheck::kNone) {
    MotionCheckResult result;
    result.inlier.assign(n, 1);
    return result;
  }
  if (options.outlier_check == TemporalOutlierCheck::kFundamental) {
    return fundamentalCheck(prev_pixels, cur_pixels, options);
  }

  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point3f& p = prev_points[i];
    if (p.z > 0 && p.z <= options.max_pnp_depth_m) {
      object.push_back(p);
      image.push_back(cur_pixels[i]);
    }
  }
  if (static_cast<int>(object.size()) < options.min_ransac_points) {
    return fundamentalCheck(prev_pixels, cur_pixels, options);
  }
  PnpRansacOptions ransac;
  ransac.threshold_px = options.ransac_threshold_px;
  ransac.confidence = options.ransac_confidence;
  ransac.max_iterations = options.ransac_iterations;
  const PnpRansacResult pnp = pnpRansac(object, image, calibration, ransac);
  if (!pnp.found || static_cast<int>(pnp.inliers.size()) < options.min_ransac_points / 2) {
    return fundamentalCheck(prev_pixels, cur_pixels, options);
  }
  // Refine on the inliers, then classify every match against the refined motion.
  std::vector<cv::Point3f> inlier_object;
  std::vector<cv::Point2f> inlier_image;
  for (int k : pnp.inliers) {
    inlier_object.push_back(object[k]);
    inlier_image.push_back(image[k]);
  }
  const cv::Matx33d K = cameraMatrix(calibration);
  cv::Mat R_start, rvec, tvec;
  cv::eigen2cv(pnp.cur_R_prev, R_start);
  cv::Rodrigues(R_start, rvec);
  cv::eigen2cv(pnp.cur_t_prev, tvec);
  cv::solvePnPRefineLM(inlier_object, inlier_image, K, cv::noArray(), rvec, tvec);

  MotionCheckResult result;
  result.checked = true;
  result.has_motion = true;
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  cv::cv2eigen(R, result.cur_R_prev);
  cv::cv2eigen(tvec, result.cur_t_prev);
  const Eigen::Matrix3d E = se3::hat(result.cur_t_prev) * result.cur_R_prev;
  const bool has_baseline = result.cur_t_prev.norm() > 1e-3;

  result.inlier.assign(n, 1);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point3f& p = prev_points[i];
    if (p.z > 0) {
      const Eigen::Vector3d q =
          result.cur_R_prev * Eigen::Vector3d(p.x, p.y, p.z) + result.cur_t_prev;
      if (q.z() <= 0) {
        result.inlier[i] = 0;
        continue;
      }
      // Far points: depth is uncertain, so only near ones are held to the reprojection.
      if (p.z <= options.max_pnp_depth_m) {
        const Eigen::Vector2d pixel = project(calibration, q);
        const double du = pixel.x() - cur_pixels[i].x;
        const double dv = pixel.y() - cur_pixels[i].y;
        result.inlier[i] = std::hypot(du, dv) <= options.ransac_threshold_px;
        continue;
      }
    }
    if (has_baseline) {
      result.inlier[i] = epipolarErrorPx(E, prev_pixels[i], cur_pixels[i], calibration) <=
                         options.ransac_threshold_px;
    }
  }
  return result;
}

}  // namespace ekf_vislam
