#include "ekf_vislam/tracker/feature_detector.h"

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace ekf_vislam {

std::vector<uint8_t> keepApart(const std::vector<cv::Point2f>& points, double min_distance) {
  std::vector<uint8_t> keep(points.size(), 1);
  if (!(min_distance > 0) || points.size() < 2) return keep;
  // Kept points by square cell of side min_distance: a point closer than that to a kept one lies
  // in its cell or one of the eight around it.
  const auto key = [min_distance](float x, float y) {
    return std::make_pair(static_cast<long>(std::floor(x / min_distance)),
                          static_cast<long>(std::floor(y / min_distance)));
  };
  std::map<std::pair<long, long>, std::vector<cv::Point2f>> kept;
  const double min_squared = min_distance * min_distance;
  for (size_t i = 0; i < points.size(); ++i) {
    const cv::Point2f& p = points[i];
    const auto [cx, cy] = key(p.x, p.y);
    bool crowded = false;
    for (long dx = -1; dx <= 1 && !crowded; ++dx) {
      for (long dy = -1; dy <= 1 && !crowded; ++dy) {
        const auto cell = kept.find({cx + dx, cy + dy});
        if (cell == kept.end()) continue;
        for (const cv::Point2f& q : cell->second) {
          const double ex = p.x - q.x, ey = p.y - q.y;
          if (ex * ex + ey * ey < min_squared) {
            crowded = true;
            break;
          }
        }
      }
    }
    if (crowded) {
      keep[i] = 0;
    } else {
      kept[{cx, cy}].push_back(p);
    }
  }
  return keep;
}

int GridFeatureDetector::cellOf(const cv::Point2f& point, const cv::Size& size) const {
  if (point.x < 0 || point.y < 0 || point.x >= size.width || point.y >= size.height) return -1;
  const int col =
      std::min(options_.grid_cols - 1, static_cast<int>(point.x * options_.grid_cols / size.width));
  const int row = std::min(options_.grid_rows - 1,
                           static_cast<int>(point.y * options_.grid_rows / size.height));
  return row * options_.grid_cols + col;
}

std::vector<cv::KeyPoint> GridFeatureDetector::independentCandidates(const cv::Mat& image) const {
  std::vector<cv::KeyPoint> keypoints;
  if (candidatesIndependent()) cv::FAST(image, keypoints, options_.fast_threshold, true);
  return keypoints;
}

std::vector<cv::KeyPoint> GridFeatureDetector::candidates(const cv::Mat& image,
                                                          const cv::Mat& free_mask) const {
  if (candidatesIndependent()) return independentCandidates(image);
  std::vector<cv::Point2f> corners;
  const int wanted = 4 * options_.grid_cols * options_.grid_rows * options_.max_features_per_cell;
  cv::goodFeaturesToTrack(image, corners, wanted, options_.shi_tomasi_quality,
                          std::max(1.0, options_.min_feature_distance), free_mask, 3);
  // goodFeaturesToTrack returns the strongest first: keep that order as the response.
  std::vector<cv::KeyPoint> keypoints;
  keypoints.reserve(corners.size());
  for (size_t i = 0; i < corners.size(); ++i) {
    keypoints.emplace_back(corners[i], 1.f, -1.f, static_cast<float>(corners.size() - i));
  }
  return keypoints;
}

std::vector<cv::Point2f> GridFeatureDetector::detect(const cv::Mat& image,
                                                     const std::vector<cv::Point2f>& existing,
                                                     const cv::Mat& usable,
                                                     const std::vector<cv::KeyPoint>* found) const {
  const cv::Size size = image.size();
  const int num_cells = options_.grid_cols * options_.grid_rows;
  std::vector<int> cell_count(num_cells, 0);

  // Free where a new corner may go: inside the border, away from every existing feature.
  cv::Mat free_mask(size, CV_8UC1, cv::Scalar(0));
  const int border = options_.border_px;
  if (size.width <= 2 * border || size.height <= 2 * border) return {};
  free_mask(cv::Rect(border, border, size.width - 2 * border, size.height - 2 * border)).setTo(255);
  if (!usable.empty()) free_mask.setTo(0, usable == 0);
  const int radius = static_cast<int>(std::ceil(options_.min_feature_distance));
  for (const cv::Point2f& p : existing) {
    const int cell = cellOf(p, size);
    if (cell >= 0) ++cell_count[cell];
    if (radius > 0) cv::circle(free_mask, p, radius, cv::Scalar(0), -1);
  }

  std::vector<cv::KeyPoint> searched;
  const std::vector<cv::KeyPoint>* keypoints = found;
  if (keypoints == nullptr || !candidatesIndependent()) {
    searched = candidates(image, free_mask);
    keypoints = &searched;
  }
  std::vector<std::vector<const cv::KeyPoint*>> by_cell(num_cells);
  for (const cv::KeyPoint& kp : *keypoints) {
    const int cell = cellOf(kp.pt, size);
    if (cell >= 0 && cell_count[cell] < options_.max_features_per_cell) {
      by_cell[cell].push_back(&kp);
    }
  }
  std::vector<cv::Point2f> added;
  for (int cell = 0; cell < num_cells; ++cell) {
    auto& list = by_cell[cell];
    std::sort(list.begin(), list.end(), [](const cv::KeyPoint* a, const cv::KeyPoint* b) {
      return a->response > b->response;
    });
    for (const cv::KeyPoint* kp : list) {
      if (cell_count[cell] >= options_.max_features_per_cell) break;
      const cv::Point pixel(cvRound(kp->pt.x), cvRound(kp->pt.y));
      if (pixel.x < 0 || pixel.y < 0 || pixel.x >= size.width || pixel.y >= size.height) continue;
      if (free_mask.at<uint8_t>(pixel) == 0) continue;
      added.push_back(kp->pt);
      ++cell_count[cell];
      if (radius > 0) cv::circle(free_mask, kp->pt, radius, cv::Scalar(0), -1);
    }
  }
  return added;
}

}  // namespace ekf_vislam
