#include "ekf_vislam/tracker/rectified_stereo.h"

namespace ekf_vislam {

StereoCalibration rectifiedPair(double fx, double fy, double cx, double cy, double baseline) {
  StereoCalibration pair;
  pair.fx = fx;
  pair.fy = fy;
  pair.cx = cx;
  pair.cy = cy;
  pair.baseline = baseline;
  return pair;
}

bool sameRectifiedPair(const StereoCalibration& a, const StereoCalibration& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.baseline == b.baseline;
}

Eigen::Vector3d normalized(const StereoCalibration& calibration, const cv::Point2f& pixel) {
  return Eigen::Vector3d((pixel.x - calibration.cx) / calibration.fx,
                         (pixel.y - calibration.cy) / calibration.fy, 1.0);
}

std::optional<Eigen::Vector3d> triangulate(const StereoCalibration& calibration,
                                           const cv::Point2f& left, double disparity) {
  if (!(disparity > 0)) return std::nullopt;
  const double z = calibration.fx * calibration.baseline / disparity;
  return Eigen::Vector3d((left.x - calibration.cx) * z / calibration.fx,
                         (left.y - calibration.cy) * z / calibration.fy, z);
}

Eigen::Vector2d project(const StereoCalibration& calibration, const Eigen::Vector3d& p_cam) {
  return Eigen::Vector2d(calibration.fx * p_cam.x() / p_cam.z() + calibration.cx,
                         calibration.fy * p_cam.y() / p_cam.z() + calibration.cy);
}

cv::Matx33d cameraMatrix(const StereoCalibration& calibration) {
  return cv::Matx33d(calibration.fx, 0, calibration.cx, 0, calibration.fy, calibration.cy, 0, 0, 1);
}

double disparityAtDepth(const StereoCalibration& calibration, double z) {
  return calibration.fx * calibration.baseline / z;
}

}  // namespace ekf_vislam
