#include "ekf_vislam/tracker/stereo_matcher.h"

#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/klt_back_check.h"
#include "ekf_vislam/tracker/patch_refiner.h"

#include <algorithm>
#include <cmath>

namespace ekf_vislam {

namespace {

// The current left patch aligned to the right image from each KLT match in `matched` (indices
// into left and *right), each on its own (on OpenCV's threads, like its KLT); a refused alignment
// leaves the KLT match. Returns how many were aligned.
int refineMatches(const cv::Mat& left_image, const cv::Mat& right_image,
                  const std::vector<cv::Point2f>& left, const std::vector<size_t>& matched,
                  const TrackerOptions& options, std::vector<cv::Point2f>* right_points) {
  std::vector<cv::Point2f>& right = *right_points;
  PatchRefinerOptions refiner;
  refiner.max_iterations = options.refine_max_iterations;
  refiner.epsilon = options.refine_epsilon;
  std::vector<uint8_t> refined_ok(matched.size(), 0);
  cv::parallel_for_(cv::Range(0, static_cast<int>(matched.size())), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      const size_t i = matched[j];
      const cv::Point2f r = right[i];
      ReferencePatch patch;
      if (!patch.create(left_image, left[i], options.refine_patch_size, WarpModel::kStereo)) {
        continue;
      }
      AffineWarp warp;
      warp.t = Eigen::Vector2f(r.x, r.y);
      const RefineResult result = patch.align(right_image, refiner, &warp);
      const cv::Point2f refined(warp.t.x(), warp.t.y());
      const double refined_disparity = left[i].x - refined.x;
      if (result.inside && result.converged && result.zncc >= options.refine_min_zncc &&
          cv::norm(refined - r) <= options.refine_max_shift_px &&
          std::abs(refined.y - left[i].y) <= options.row_tolerance_px &&
          refined_disparity >= options.min_disparity_px &&
          refined_disparity <= options.max_disparity_px) {
        right[i] = refined;
        refined_ok[j] = 1;
      }
    }
  });
  return static_cast<int>(std::count(refined_ok.begin(), refined_ok.end(), 1));
}

}  // namespace

std::vector<cv::Point2f> matchStereo(const std::vector<cv::Mat>& left_pyramid,
                                     const std::vector<cv::Mat>& right_pyramid,
                                     const std::vector<cv::Point2f>& left,
                                     const std::vector<float>& seed_disparity,
                                     const TrackerOptions& options, bool refine,
                                     const cv::Mat& right_mask, std::vector<uint8_t>* ok,
                                     StereoMatchCounts* counts) {
  const size_t n = left.size();
  ok->assign(n, 0);
  std::vector<cv::Point2f> right(n);
  if (n == 0) return right;
  for (size_t i = 0; i < n; ++i) right[i] = cv::Point2f(left[i].x - seed_disparity[i], left[i].y);

  const cv::Size window(options.stereo_window_size, options.stereo_window_size);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                  options.max_iterations, options.epsilon);
  const KltSettings klt{window, options.stereo_pyramid_levels, criteria};
  std::vector<uint8_t> status;
  trackPyramidalKlt(left_pyramid, right_pyramid, left, &right, &status, klt);

  // The checks on the match itself first: only what passes them is matched back.
  const cv::Size size = left_pyramid[0].size();
  std::vector<size_t> candidates;
  candidates.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f r = right[i];
    const double disparity = left[i].x - r.x;
    if (!status[i] || r.x < 0 || r.y < 0 || r.x > size.width - 1 || r.y > size.height - 1) {
      ++counts->klt_failed;
      continue;
    }
    counts->row_offsets.push_back(r.y - left[i].y);
    counts->row_offset_left.push_back(left[i]);
    if (std::abs(r.y - left[i].y) > options.row_tolerance_px) {
      ++counts->row_failed;
    } else if (disparity < options.min_disparity_px || disparity > options.max_disparity_px) {
      ++counts->disparity_failed;
      if (disparity < 0) ++counts->negative_disparity;
    } else {
      candidates.push_back(i);
    }
  }
  const std::vector<uint8_t> back_ok =
      backCheck(right_pyramid, left_pyramid, right, left, candidates,
                backCheckSettings(klt, options.back_check_levels), options.stereo_back_check_px);

  std::vector<size_t> matched;
  matched.reserve(candidates.size());
  for (const size_t i : candidates) {
    if (!back_ok[i]) {
      ++counts->back_check_failed;
      continue;
    }
    (*ok)[i] = 1;
    matched.push_back(i);
  }
  counts->matched += static_cast<int>(matched.size());
  if (refine && options.refine && options.refine_stereo) {
    counts->refined +=
        refineMatches(left_pyramid[0], right_pyramid[0], left, matched, options, &right);
  }
  counts->masked += refuseMaskedPoints(right_mask, right, ok);
  return right;
}

}  // namespace ekf_vislam
