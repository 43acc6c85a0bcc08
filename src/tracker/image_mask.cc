#include "ekf_vislam/tracker/image_mask.h"

#include <opencv2/imgcodecs.hpp>

#include <fstream>

namespace ekf_vislam {

namespace {

bool loadMask(const char* key, const std::string& path, cv::Mat* mask, std::string* error) {
  mask->release();
  if (path.empty()) return true;
  if (!std::ifstream(path)) {
    *error = std::string("'") + key + "': cannot open " + path;
    return false;
  }
  *mask = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (mask->empty()) {
    *error = std::string("'") + key + "': not an image OpenCV reads: " + path;
    return false;
  }
  return true;
}

std::string sizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

}  // namespace

bool loadStereoMasks(const TrackerOptions& options, StereoMasks* masks, std::string* error) {
  StereoMasks loaded;
  if (!loadMask("mask/left", options.mask_left, &loaded.left, error) ||
      !loadMask("mask/right", options.mask_right, &loaded.right, error)) {
    return false;
  }
  *masks = std::move(loaded);
  return true;
}

std::string checkMaskSizes(const StereoMasks& masks, const cv::Size& image_size) {
  for (const auto& [key, mask] :
       {std::make_pair("mask/left", &masks.left), std::make_pair("mask/right", &masks.right)}) {
    if (!mask->empty() && mask->size() != image_size) {
      return std::string("the '") + key + "' image is " + sizeText(mask->size()) +
             ", the camera images " + sizeText(image_size);
    }
  }
  return "";
}

bool usablePixel(const cv::Mat& mask, const cv::Point2f& point) {
  if (mask.empty()) return true;
  const int u = cvRound(point.x), v = cvRound(point.y);
  if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows) return false;
  return mask.at<uint8_t>(v, u) != 0;
}

int refuseMaskedPoints(const cv::Mat& mask, const std::vector<cv::Point2f>& points,
                       std::vector<uint8_t>* ok) {
  if (mask.empty()) return 0;
  int refused = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if ((*ok)[i] && !usablePixel(mask, points[i])) {
      (*ok)[i] = 0;
      ++refused;
    }
  }
  return refused;
}

}  // namespace ekf_vislam
