#include "ekf_vislam/tracker/stereo_matcher.h"

#include "ekf_vislam/tracker/patch_refiner.h"

#include <opencv2/video/tracking.hpp>

#include <cmath>

namespace ekf_vislam {

std::vector<cv::Point2f> matchStereo(const std::vector<cv::Mat>& left_pyramid,
                                     const std::vector<cv::Mat>& right_pyramid,
                                     const std::vector<cv::Point2f>& left,
                                     const std::vector<float>& seed_disparity,
                                     const TrackerOptions& options, bool refine,
                                     std::vector<uint8_t>* ok, StereoMatchCounts* counts) {
  const size_t n = left.size();
  ok->assign(n, 0);
  std::vector<cv::Point2f> right(n);
  if (n == 0) return right;
  for (size_t i = 0; i < n; ++i) right[i] = cv::Point2f(left[i].x - seed_disparity[i], left[i].y);

  const cv::Size window(options.stereo_window_size, options.stereo_window_size);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                  options.max_iterations, options.epsilon);
  std::vector<uint8_t> status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(left_pyramid, right_pyramid, left, right, status, error, window,
                           options.stereo_pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<cv::Point2f> back = left;
  std::vector<uint8_t> back_status;
  cv::calcOpticalFlowPyrLK(right_pyramid, left_pyramid, right, back, back_status, error, window,
                           options.stereo_pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);

  const cv::Size size = left_pyramid[0].size();
  PatchRefinerOptions refiner;
  refiner.max_iterations = options.refine_max_iterations;
  refiner.epsilon = options.refine_epsilon;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f r = right[i];
    if (!status[i] || r.x < 0 || r.y < 0 || r.x > size.width - 1 || r.y > size.height - 1) {
      ++counts->klt_failed;
      continue;
    }
    if (!back_status[i] || cv::norm(back[i] - left[i]) > options.stereo_back_check_px) {
      ++counts->back_check_failed;
      continue;
    }
    if (std::abs(r.y - left[i].y) > options.row_tolerance_px) {
      ++counts->row_failed;
      continue;
    }
    const double disparity = left[i].x - r.x;
    if (disparity < options.min_disparity_px || disparity > options.max_disparity_px) {
      ++counts->disparity_failed;
      continue;
    }
    (*ok)[i] = 1;
    ++counts->matched;
    if (refine && options.refine && options.refine_stereo) {
      // The current left patch aligned to the right image from the KLT match.
      ReferencePatch patch;
      if (!patch.create(left_pyramid[0], left[i], options.refine_patch_size, WarpModel::kStereo)) {
        continue;
      }
      AffineWarp warp;
      warp.t = Eigen::Vector2f(r.x, r.y);
      const RefineResult result = patch.align(right_pyramid[0], refiner, &warp);
      const cv::Point2f refined(warp.t.x(), warp.t.y());
      const double refined_disparity = left[i].x - refined.x;
      if (result.inside && result.converged && result.zncc >= options.refine_min_zncc &&
          cv::norm(refined - r) <= options.refine_max_shift_px &&
          std::abs(refined.y - left[i].y) <= options.row_tolerance_px &&
          refined_disparity >= options.min_disparity_px &&
          refined_disparity <= options.max_disparity_px) {
        right[i] = refined;
        ++counts->refined;
      }
    }
  }
  return right;
}

}  // namespace ekf_vislam
