#include "ekf_vislam/tracker/image_rectifier.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>

namespace ekf_vislam {

namespace {

size_t expectedCoefficients(const std::string& distortion_model) {
  if (distortion_model == "plumb_bob") return 5;
  if (distortion_model == "rational_polynomial") return 8;
  if (distortion_model == "equidistant") return 4;
  return 0;
}

cv::Mat matrix(const double* values, int rows, int cols) {
  return cv::Mat(rows, cols, CV_64F, const_cast<double*>(values)).clone();
}

template <class Values>
bool allFinite(const Values& values) {
  return std::all_of(std::begin(values), std::end(values),
                     [](double v) { return std::isfinite(v); });
}

bool isRotation(const cv::Mat& R) {
  const cv::Mat should_be_identity = R * R.t();
  return cv::norm(should_be_identity - cv::Mat::eye(3, 3, CV_64F), cv::NORM_INF) < 1e-3 &&
         cv::determinant(R) > 0.0;
}

}  // namespace

bool RawCameraModel::operator==(const RawCameraModel& other) const {
  return width == other.width && height == other.height &&
         distortion_model == other.distortion_model && D == other.D && K == other.K &&
         R == other.R && P == other.P;
}

bool ImageRectifier::reset(const RawCameraModel& model, std::string* why) {
  map_xy_.release();
  map_fraction_.release();
  const size_t coefficients = expectedCoefficients(model.distortion_model);
  if (coefficients == 0) {
    *why = "distortion model '" + model.distortion_model +
           "' (expected plumb_bob, rational_polynomial or equidistant)";
    return false;
  }
  // plumb_bob with 4 coefficients (k3 left out) is common; fewer are taken as zeros too.
  if (model.D.size() > coefficients) {
    *why = model.distortion_model + " with " + std::to_string(model.D.size()) +
           " distortion coefficients (at most " + std::to_string(coefficients) + ")";
    return false;
  }
  const bool finite =
      allFinite(model.D) && allFinite(model.K) && allFinite(model.R) && allFinite(model.P);
  if (!finite || model.width <= 0 || model.height <= 0 || !(model.K[0] > 0) || !(model.K[4] > 0) ||
      !(model.P[0] > 0) || !(model.P[5] > 0)) {
    *why = "camera model without a size, or K or P not a camera's (fx, fy > 0, finite)";
    return false;
  }
  const cv::Mat R = matrix(model.R.data(), 3, 3);
  if (!isRotation(R)) {
    *why = "R is not a rotation";
    return false;
  }
  std::vector<double> D = model.D;
  D.resize(coefficients, 0.0);
  const cv::Mat K = matrix(model.K.data(), 3, 3);
  const cv::Mat new_K = matrix(model.P.data(), 3, 4)(cv::Rect(0, 0, 3, 3)).clone();
  const cv::Size size(model.width, model.height);
  if (model.distortion_model == "equidistant") {
    cv::fisheye::initUndistortRectifyMap(K, D, R, new_K, size, CV_16SC2, map_xy_, map_fraction_);
  } else {
    cv::initUndistortRectifyMap(K, D, R, new_K, size, CV_16SC2, map_xy_, map_fraction_);
  }
  model_ = model;  // as given: the caller compares the next camera_info's model with it
  distortion_ = D;
  return true;
}

bool ImageRectifier::rectify(const cv::Mat& raw, cv::Mat* rectified) const {
  if (!ready() || raw.type() != CV_8UC1 || raw.cols != model_.width || raw.rows != model_.height) {
    return false;
  }
  cv::remap(raw, *rectified, map_xy_, map_fraction_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  return true;
}

cv::Point2d ImageRectifier::rectifiedPixel(const cv::Point2d& raw_pixel) const {
  const cv::Mat K = matrix(model_.K.data(), 3, 3);
  const cv::Mat R = matrix(model_.R.data(), 3, 3);
  const cv::Mat P = matrix(model_.P.data(), 3, 4);
  std::vector<cv::Point2d> in{raw_pixel}, out;
  if (model_.distortion_model == "equidistant") {
    cv::fisheye::undistortPoints(in, out, K, distortion_, R, P);
  } else {
    cv::undistortPoints(
        in, out, K, distortion_, R, P,
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-10));
  }
  return out.front();
}

}  // namespace ekf_vislam
