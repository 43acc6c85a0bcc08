#include "ekf_vislam/tracker/stereo_tracker.h"

#include "ekf_vislam/core/median.h"
#include "ekf_vislam/tracker/disparity_offset_fit.h"
#include "ekf_vislam/tracker/exposure_compensation.h"
#include "ekf_vislam/tracker/klt_back_check.h"
#include "ekf_vislam/tracker/motion_check.h"
#include "ekf_vislam/tracker/rectified_stereo.h"
#include "ekf_vislam/tracker/stereo_matcher.h"
#include "ekf_vislam/tracker/stereo_roll_fit.h"

#include <Eigen/Geometry>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <optional>
#include <utility>

namespace ekf_vislam {

namespace {

constexpr size_t kTrailLength = 10;
// Fewest tracks an exposure map is fitted on (klt/exposure_compensation).
constexpr int kMinExposurePoints = 20;

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The motion over `ratio` times the interval of `motion` (constant velocity).
CameraMotionPrior scaleMotion(const CameraMotionPrior& motion, double ratio) {
  CameraMotionPrior scaled;
  const Eigen::AngleAxisd angle_axis(motion.cur_R_prev);
  scaled.cur_R_prev = Eigen::AngleAxisd(angle_axis.angle() * ratio, angle_axis.axis()).matrix();
  scaled.has_translation = motion.has_translation;
  scaled.cur_t_prev = motion.cur_t_prev * ratio;
  return scaled;
}

// The window the pyramids are built for (both KLT steps use them).
cv::Size pyramidWindow(const TrackerOptions& options) {
  const int side = std::max(options.window_size, options.stereo_window_size);
  return cv::Size(side, side);
}

bool insideImage(const cv::Point2f& p, const cv::Size& size, int border) {
  return p.x >= border && p.y >= border && p.x <= size.width - 1 - border &&
         p.y <= size.height - 1 - border;
}

template <typename T>
void keepSelected(const std::vector<uint8_t>& keep, std::vector<T>* items) {
  size_t out = 0;
  for (size_t i = 0; i < items->size(); ++i) {
    if (!keep[i]) continue;
    // No self-move: a moved-onto-itself std::vector may come out empty.
    if (out != i) (*items)[out] = std::move((*items)[i]);
    ++out;
  }
  items->resize(out);
}

// A track nearer than this fraction of detector/min_feature_distance to an older one ends
// (endCrowdedTracks). Below 1, so that new corners placed at that distance from their neighbours
// do not end as soon as the image contracts a little: tracks may come twice as near as corners
// are placed.
constexpr double kCrowdedFraction = 0.5;

// Tracks the motion is first fitted on when there is no prediction (predictFromFirstMatches).
constexpr size_t kFirstMatchTracks = 100;

struct TemporalKltResult {
  std::vector<uint8_t> passed;  ///< per point: tracked inside the border and back-checked
  int lost = 0;                 ///< KLT failed or left the border
  int back_check_failed = 0;
};

// The temporal KLT from `prev` (start points *cur) into the new left image, and its
// forward-backward check. Without a prediction it searches one pyramid level more.
TemporalKltResult temporalKlt(const std::vector<cv::Mat>& prev_pyramid,
                              const std::vector<cv::Mat>& left_pyramid, bool predicted,
                              const std::vector<cv::Point2f>& prev, std::vector<cv::Point2f>* cur,
                              const TrackerOptions& options) {
  const KltSettings klt{cv::Size(options.window_size, options.window_size),
                        options.pyramid_levels + (predicted ? 0 : 1),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                         options.max_iterations, options.epsilon)};
  TemporalKltResult result;
  if (prev.empty()) return result;
  std::vector<uint8_t> status;
  trackPyramidalKlt(prev_pyramid, left_pyramid, prev, cur, &status, klt);
  const cv::Size size = left_pyramid[0].size();
  std::vector<size_t> candidates;
  candidates.reserve(prev.size());
  for (size_t i = 0; i < prev.size(); ++i) {
    if (!status[i] || !insideImage((*cur)[i], size, options.border_px)) {
      ++result.lost;
    } else {
      candidates.push_back(i);
    }
  }
  result.passed =
      backCheck(left_pyramid, prev_pyramid, *cur, prev, candidates,
                backCheckSettings(klt, options.back_check_levels), options.forward_backward_px);
  result.back_check_failed =
      static_cast<int>(candidates.size()) -
      static_cast<int>(std::count(result.passed.begin(), result.passed.end(), 1));
  return result;
}

// Where a track's stereo point is seen: its left column, the mean of both images' rows (half a
// float sum is exact in float). pointOf and the rig's offset fit both place it there.
cv::Point2f stereoPixelOf(const cv::Point2f& left, const cv::Point2f& right) {
  return cv::Point2f(left.x, 0.5f * (left.y + right.y));
}

// The motion a RANSAC found (check.has_motion), as a prediction of the next start points.
CameraMotionPrior motionPriorOf(const MotionCheckResult& check) {
  CameraMotionPrior motion;
  motion.cur_R_prev = check.cur_R_prev;
  motion.cur_t_prev = check.cur_t_prev;
  motion.has_translation = true;
  return motion;
}

// The frame's left-right matches in the figures the rig check reads (stereo_rig_check.h). The
// roll is fitted to the matches within twice the row tolerance of its line: the row test's own
// matches and their neighbours, not the wrong matches of other rows.
void summarizeStereoMatches(StereoMatchCounts counts, const StereoCalibration& calibration,
                            int image_width, double row_tolerance_px, TrackerFrameStats* stats) {
  stats->stereo_converged = counts.converged();
  stats->stereo_row_failed = counts.row_failed;
  stats->stereo_negative_disparity = counts.negative_disparity;
  const cv::Point2f principal_point(static_cast<float>(calibration.cx),
                                    static_cast<float>(calibration.cy));
  const StereoRollFit roll = fitStereoRoll(counts.row_offset_left, counts.row_offsets,
                                           principal_point, 2.0 * row_tolerance_px);
  if (roll.fitted) {
    constexpr double kDegreesPerRadian = 180.0 / M_PI;
    stats->stereo_roll_deg = static_cast<float>(roll.roll_rad * kDegreesPerRadian);
    stats->stereo_roll_sigma_deg = static_cast<float>(roll.roll_sigma_rad * kDegreesPerRadian);
    const double farther_edge = std::max(calibration.cx, image_width - 1 - calibration.cx);
    stats->stereo_roll_edge_px = static_cast<float>(roll.roll_rad * farther_edge);
  }
  if (!counts.row_offsets.empty()) stats->stereo_row_offset_px = upperMedian(&counts.row_offsets);
}

}  // namespace

StereoTracker::StereoTracker(const TrackerOptions& options, const StereoCalibration& calibration,
                             StereoMasks masks, uint32_t first_id)
    : options_(options),
      calibration_(calibration),
      masks_(std::move(masks)),
      detector_(options),
      next_id_(first_id),
      rig_check_(options.row_tolerance_px, options.correct_disparity_offset) {}

void StereoTracker::reset() {
  tracks_.clear();
  rig_check_.reset();
  prev_left_pyramid_.clear();
  has_prev_ = false;
  has_last_motion_ = false;
}

cv::Point3f StereoTracker::pointOf(const Track& track) const {
  const std::optional<Eigen::Vector3d> p_cam = triangulate(
      calibration_, stereoPixelOf(track.left, track.right), track.left.x - track.right.x);
  if (!p_cam) return cv::Point3f(0, 0, -1);
  return cv::Point3f(static_cast<float>(p_cam->x()), static_cast<float>(p_cam->y()),
                     static_cast<float>(p_cam->z()));
}

bool StereoTracker::predictLeft(const CameraMotionPrior* prior, double dt, CameraMotionPrior* used,
                                std::vector<cv::Point2f>* predicted) const {
  const double ratio = last_dt_ > 0 ? std::clamp(dt / last_dt_, 0.0, 3.0) : 1.0;
  *used = CameraMotionPrior();
  bool has_prediction = true;
  if (prior != nullptr) {
    *used = *prior;
    if (!prior->has_translation && has_last_motion_) {
      used->has_translation = true;
      used->cur_t_prev = last_motion_.cur_t_prev * ratio;
    }
  } else if (options_.predict_with_last_motion && has_last_motion_) {
    *used = scaleMotion(last_motion_, ratio);
  } else {
    has_prediction = false;
  }
  const Eigen::Matrix3d& R = used->cur_R_prev;
  predicted->resize(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const Track& track = tracks_[i];
    const cv::Point3f p = pointOf(track);
    Eigen::Vector3d q;
    if (used->has_translation && p.z > 0) {
      q = R * Eigen::Vector3d(p.x, p.y, p.z) + used->cur_t_prev;
    } else {  // rotation only: the point at infinity
      q = R * normalized(calibration_, track.left);
    }
    if (q.z() < 0.1) {
      (*predicted)[i] = track.left;
      continue;
    }
    const Eigen::Vector2d pixel = project(calibration_, q);
    (*predicted)[i] = cv::Point2f(static_cast<float>(pixel.x()), static_cast<float>(pixel.y()));
  }
  return has_prediction;
}

std::string StereoTracker::inputProblem(const cv::Mat& left, const cv::Mat& right,
                                        double stamp) const {
  const int min_size =
      2 * options_.border_px + std::max(options_.window_size, options_.stereo_window_size);
  if (left.empty() || right.empty()) return "empty image";
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1) {
    return "images must be 8-bit single channel";
  }
  if (left.size() != right.size()) return "left and right images differ in size";
  if (left.cols < min_size || left.rows < min_size) {
    return "image smaller than twice the border plus the KLT window";
  }
  if (std::string mask_problem = checkMaskSizes(masks_, left.size()); !mask_problem.empty()) {
    return mask_problem;
  }
  if (!std::isfinite(stamp) || (has_prev_ && stamp <= prev_stamp_)) {
    return "time stamp not after the previous pair's";
  }
  return "";
}

bool StereoTracker::process(const cv::Mat& left, const cv::Mat& right, double stamp,
                            const CameraMotionPrior* prior, StereoFrame* frame, std::string* why) {
  const auto start = Clock::now();
  if (std::string problem = inputProblem(left, right, stamp); !problem.empty()) {
    *why = std::move(problem);
    return false;
  }
  if (has_prev_ && left.size() != image_size_) reset();

  TrackerFrameStats stats;
  stats.tracks_in = static_cast<int>(tracks_.size());
  // The temporal KLT takes one level more without a prediction (trackTemporal).
  const int levels = std::max(options_.pyramid_levels + 1, options_.stereo_pyramid_levels);
  const cv::Size window = pyramidWindow(options_);
  // The new left image's pyramid and FAST corners do not depend on the tracks: two more threads
  // make them while this one predicts the tracks and brings the previous pyramid to the new
  // exposure or, without tracks, builds the right pyramid (the results are those made in turn,
  // bit for bit). What they write is declared before their futures, which wait for them on every
  // way out.
  std::vector<cv::Mat>& left_pyramid = left_pyramid_;
  const std::vector<cv::Mat>& right_pyramid = right_pyramid_;
  std::vector<cv::KeyPoint> corners_found;
  std::future<void> left_pyramid_built = std::async(std::launch::async, [&] {
    cv::buildOpticalFlowPyramid(left, left_pyramid, window, levels, true);
  });
  std::future<void> corners_searched;
  if (detector_.candidatesIndependent()) {
    corners_searched = std::async(std::launch::async,
                                  [&] { corners_found = detector_.independentCandidates(left); });
  }

  std::optional<TemporalStart> temporal;
  std::vector<float> predicted_disparity;
  if (has_prev_ && !tracks_.empty()) {
    temporal = startTemporal(left, prior, stamp - prev_stamp_, &stats);
  } else {
    tracks_.clear();
    has_last_motion_ = false;
    // Without tracks the stereo exposure map stands: the right pyramid is built while the left
    // one is.
    buildRightPyramid(left, right, predicted_disparity, levels, &stats);
  }
  auto t = Clock::now();
  left_pyramid_built.get();
  stats.ms_pyramids += msSince(t);
  if (temporal) {
    predicted_disparity = trackTemporal(std::move(*temporal), left_pyramid, &stats);
    endCrowdedTracks(&predicted_disparity, &stats);
    buildRightPyramid(left, right, predicted_disparity, levels, &stats);
  }
  t = Clock::now();
  StereoMatchCounts stereo_counts;
  matchTracksInRight(left_pyramid, right_pyramid, predicted_disparity, &stereo_counts, &stats);
  stats.ms_stereo = msSince(t);
  t = Clock::now();
  if (corners_searched.valid()) corners_searched.get();
  stats.ms_detect = msSince(t);
  addNewTracks(left, left_pyramid, right_pyramid,
               detector_.candidatesIndependent() ? &corners_found : nullptr, &stereo_counts,
               &stats);
  summarizeStereoMatches(std::move(stereo_counts), calibration_, left.cols,
                         options_.row_tolerance_px, &stats);

  std::swap(prev_left_pyramid_, left_pyramid_);
  image_size_ = left.size();
  if (has_prev_) last_dt_ = stamp - prev_stamp_;
  prev_stamp_ = stamp;
  has_prev_ = true;
  correctDisparityOffset(&stats);
  stats.ms_total = msSince(start);
  frame->stats = stats;
  fillFrame(stamp, frame);
  return true;
}

void StereoTracker::correctDisparityOffset(TrackerFrameStats* stats) {
  const bool was_correcting = rig_check_.correcting();
  rig_check_.add(*stats);
  if (!options_.correct_disparity_offset) return;
  if (rig_check_.correcting() && !was_correcting) {
    // Every published track goes on under a new id: the estimator made its landmark from
    // disparities with the offset in, and starts the new id from the corrected ones.
    for (Track& track : tracks_) {
      if (!track.has_id) continue;
      track.has_id = false;
      track.age = options_.confirm_frames;
      ++stats->ids_renewed;
    }
  }
  stats->disparity_offset_corrected_px = static_cast<float>(rig_check_.disparityCorrectionPx());
}

StereoTracker::TemporalStart StereoTracker::startTemporal(const cv::Mat& left,
                                                          const CameraMotionPrior* prior, double dt,
                                                          TrackerFrameStats* stats) {
  const auto t = Clock::now();
  TemporalStart start;
  start.prev.resize(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) start.prev[i] = tracks_[i].left;
  // Without a prediction (a second pair without a twist), the tracks start where they were:
  // search one pyramid level more.
  start.predicted = predictLeft(prior, dt, &start.prediction, &start.cur);
  stats->ms_temporal = msSince(t);
  bringPreviousPyramidToExposure(left, start.prev, start.cur, stats);
  return start;
}

std::vector<float> StereoTracker::trackTemporal(TemporalStart start,
                                                const std::vector<cv::Mat>& left_pyramid,
                                                TrackerFrameStats* stats) {
  const auto t = Clock::now();
  const std::vector<cv::Mat>& prev_pyramid = prev_left_pyramid_;
  if (!start.predicted && options_.predict_with_last_motion) {
    stats->predicted_from_first_matches =
        predictFromFirstMatches(prev_pyramid, left_pyramid, &start);
  }
  std::vector<cv::Point2f>& prev = start.prev;
  std::vector<cv::Point2f>& cur = start.cur;
  followTracks(prev_pyramid, left_pyramid, start.predicted, &prev, &cur, stats);
  stats->ms_temporal += msSince(t);
  if (options_.refine) {
    const auto t_refine = Clock::now();
    keepTracks(refineLeft(left_pyramid[0], &cur, stats), &prev, &cur);
    stats->ms_refine = msSince(t_refine);
  }
  // A track now on a masked pixel ends (mask/left; after the refinement, which may move it).
  if (!masks_.left.empty()) {
    std::vector<uint8_t> unmasked(tracks_.size(), 1);
    stats->klt_lost += refuseMaskedPoints(masks_.left, cur, &unmasked);
    keepTracks(unmasked, &prev, &cur);
  }
  return checkMotion(prev, cur, start.prediction, stats);
}

void StereoTracker::bringPreviousPyramidToExposure(const cv::Mat& left,
                                                   const std::vector<cv::Point2f>& prev,
                                                   const std::vector<cv::Point2f>& cur,
                                                   TrackerFrameStats* stats) {
  if (!options_.exposure_compensation) return;
  const auto t = Clock::now();
  const cv::Mat& prev_image = prev_left_pyramid_[0];
  const std::optional<IntensityMap> map =
      fitIntensityMap(prev_image, prev, left, cur, options_.window_size, kMinExposurePoints);
  if (map) {
    stats->exposure_gain_temporal = map->gain;
    // The mapped image is a copy: the pyramid it came from may be written over.
    const cv::Mat exposed = applyIntensityMap(prev_image, *map);
    const int levels = static_cast<int>(prev_left_pyramid_.size() / 2) - 1;
    cv::buildOpticalFlowPyramid(exposed, prev_left_pyramid_, pyramidWindow(options_), levels, true);
  }
  stats->ms_pyramids += msSince(t);
}

void StereoTracker::followTracks(const std::vector<cv::Mat>& prev_pyramid,
                                 const std::vector<cv::Mat>& left_pyramid, bool predicted,
                                 std::vector<cv::Point2f>* prev, std::vector<cv::Point2f>* cur,
                                 TrackerFrameStats* stats) {
  const TemporalKltResult result =
      temporalKlt(prev_pyramid, left_pyramid, predicted, *prev, cur, options_);
  stats->klt_lost += result.lost;
  stats->forward_backward_rejected += result.back_check_failed;
  keepTracks(result.passed, prev, cur);
}

bool StereoTracker::predictFromFirstMatches(const std::vector<cv::Mat>& prev_pyramid,
                                            const std::vector<cv::Mat>& left_pyramid,
                                            TemporalStart* start) const {
  const size_t n = tracks_.size();
  const size_t count = std::min(n, kFirstMatchTracks);
  std::vector<cv::Point3f> points(count);
  std::vector<cv::Point2f> prev(count);
  for (size_t k = 0; k < count; ++k) {
    const size_t i = k * n / count;  // spread over the tracks, which were made cell by cell
    points[k] = pointOf(tracks_[i]);
    prev[k] = start->prev[i];
  }
  std::vector<cv::Point2f> cur = prev;
  const TemporalKltResult klt =
      temporalKlt(prev_pyramid, left_pyramid, false, prev, &cur, options_);
  keepSelected(klt.passed, &points);
  keepSelected(klt.passed, &prev);
  keepSelected(klt.passed, &cur);
  const MotionCheckResult check = checkTemporalMatches(points, prev, cur, calibration_, options_);
  if (!check.has_motion) return false;
  const CameraMotionPrior motion = motionPriorOf(check);
  start->predicted = predictLeft(&motion, 0, &start->prediction, &start->cur);
  return start->predicted;
}

void StereoTracker::keepTracks(const std::vector<uint8_t>& keep, std::vector<cv::Point2f>* prev,
                               std::vector<cv::Point2f>* cur) {
  keepSelected(keep, &tracks_);
  keepSelected(keep, prev);
  keepSelected(keep, cur);
}

std::vector<float> StereoTracker::checkMotion(const std::vector<cv::Point2f>& prev,
                                              const std::vector<cv::Point2f>& cur,
                                              const CameraMotionPrior& prediction,
                                              TrackerFrameStats* stats) {
  // RANSAC over the surviving matches, with each track's previous stereo point.
  const auto t = Clock::now();
  std::vector<cv::Point3f> prev_points(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) prev_points[i] = pointOf(tracks_[i]);
  const MotionCheckResult check =
      checkTemporalMatches(prev_points, prev, cur, calibration_, options_);
  has_last_motion_ = check.has_motion;
  stats->motion_estimated = check.has_motion;
  if (check.has_motion) {
    last_motion_ = motionPriorOf(check);
    fitRigDisparityOffset(cur, check, stats);
  }
  const CameraMotionPrior& motion = check.has_motion ? last_motion_ : prediction;
  std::vector<float> predicted_disparity(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const cv::Point3f& p = prev_points[i];
    float disparity = tracks_[i].left.x - tracks_[i].right.x;
    if (motion.has_translation && p.z > 0) {
      const Eigen::Vector3d q =
          motion.cur_R_prev * Eigen::Vector3d(p.x, p.y, p.z) + motion.cur_t_prev;
      if (q.z() > 0.1) {
        disparity = static_cast<float>(disparityAtDepth(calibration_, q.z()));
      }
    }
    predicted_disparity[i] = disparity;
    Track& track = tracks_[i];
    track.trail.push_back(track.left);
    if (track.trail.size() > kTrailLength) track.trail.erase(track.trail.begin());
    track.left = cur[i];
    ++track.age;
    if (!check.inlier[i]) ++stats->ransac_rejected;
  }
  keepSelected(check.inlier, &tracks_);
  keepSelected(check.inlier, &predicted_disparity);
  stats->ms_ransac = msSince(t);
  return predicted_disparity;
}

void StereoTracker::fitRigDisparityOffset(const std::vector<cv::Point2f>& cur,
                                          const MotionCheckResult& check,
                                          TrackerFrameStats* stats) const {
  std::vector<DisparityOffsetMatch> matches;
  matches.reserve(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const Track& track = tracks_[i];
    matches.push_back(
        {stereoPixelOf(track.left, track.right), track.left.x - track.right.x, cur[i]});
  }
  const DisparityOffsetFit fit = fitDisparityOffset(matches, check.cur_R_prev, check.cur_t_prev,
                                                    calibration_, options_.ransac_threshold_px);
  if (!fit.fitted) return;
  stats->disparity_offset_px = static_cast<float>(fit.offset_px);
  stats->disparity_offset_sigma_px = static_cast<float>(fit.offset_sigma_px);
}

void StereoTracker::endCrowdedTracks(std::vector<float>* predicted_disparity,
                                     TrackerFrameStats* stats) {
  std::vector<cv::Point2f> left(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) left[i] = tracks_[i].left;
  const std::vector<uint8_t> keep =
      keepApart(left, kCrowdedFraction * options_.min_feature_distance);
  stats->crowded = static_cast<int>(std::count(keep.begin(), keep.end(), 0));
  keepSelected(keep, &tracks_);
  keepSelected(keep, predicted_disparity);
}

void StereoTracker::buildRightPyramid(const cv::Mat& left, const cv::Mat& right,
                                      const std::vector<float>& predicted_disparity, int levels,
                                      TrackerFrameStats* stats) {
  const auto t = Clock::now();
  if (options_.exposure_compensation) {
    updateStereoExposure(left, right, predicted_disparity);
    stats->exposure_gain_stereo = stereo_exposure_.gain;
    cv::buildOpticalFlowPyramid(applyIntensityMap(right, stereo_exposure_), right_pyramid_,
                                pyramidWindow(options_), levels, true);
  } else {
    cv::buildOpticalFlowPyramid(right, right_pyramid_, pyramidWindow(options_), levels, true);
  }
  stats->ms_pyramids += msSince(t);
}

void StereoTracker::updateStereoExposure(const cv::Mat& left, const cv::Mat& right,
                                         const std::vector<float>& predicted_disparity) {
  std::vector<cv::Point2f> left_points(tracks_.size()), right_points(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    left_points[i] = tracks_[i].left;
    right_points[i] = tracks_[i].left - cv::Point2f(predicted_disparity[i], 0.f);
  }
  // Without enough tracks the last map stands (a rig's two cameras differ slowly, if at all).
  if (const std::optional<IntensityMap> map =
          fitIntensityMap(right, right_points, left, left_points, options_.stereo_window_size,
                          kMinExposurePoints)) {
    stereo_exposure_ = *map;
  }
}

void StereoTracker::setReference(const cv::Mat& left, Track* track) const {
  track->warp = AffineWarp();
  track->warp.t = Eigen::Vector2f(track->left.x, track->left.y);
  track->reference.create(left, track->left, options_.refine_patch_size, WarpModel::kAffine);
}

std::vector<uint8_t> StereoTracker::refineLeft(const cv::Mat& left, std::vector<cv::Point2f>* cur,
                                               TrackerFrameStats* stats) {
  PatchRefinerOptions refiner;
  refiner.max_iterations = options_.refine_max_iterations;
  refiner.epsilon = options_.refine_epsilon;
  const double max_scale = options_.refine_max_scale_change;
  // Each track on its own (on OpenCV's threads, like its KLT); the counts afterwards.
  enum Outcome : uint8_t { kNoReference, kAligned, kRefused };
  std::vector<uint8_t> outcome(tracks_.size(), kNoReference);
  cv::parallel_for_(cv::Range(0, static_cast<int>(tracks_.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      Track& track = tracks_[i];
      cv::Point2f& p = (*cur)[i];
      if (track.reference.valid()) {
        AffineWarp warp = track.warp;
        warp.t = Eigen::Vector2f(p.x, p.y);
        const RefineResult result = track.reference.align(left, refiner, &warp);
        const cv::Point2f refined(warp.t.x(), warp.t.y());
        outcome[i] = result.inside && result.converged && result.zncc >= options_.refine_min_zncc &&
                             cv::norm(refined - p) <= options_.refine_max_shift_px
                         ? kAligned
                         : kRefused;
        if (outcome[i] == kAligned) {
          p = refined;
          track.warp = warp;
        } else if (options_.refine_end_failed) {
          continue;
        }
      }
      const double scale = std::sqrt(std::abs(track.warp.A.determinant()));
      if (outcome[i] != kAligned || !(scale <= max_scale && scale >= 1.0 / max_scale)) {
        // A new reference where the track now is.
        Track anchored;
        anchored.left = p;
        setReference(left, &anchored);
        track.reference = std::move(anchored.reference);
        track.warp = anchored.warp;
      }
    }
  });
  std::vector<uint8_t> keep(tracks_.size(), 1);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    if (outcome[i] == kAligned) ++stats->refined;
    if (outcome[i] == kRefused) {
      ++stats->refine_failed;
      if (options_.refine_end_failed) keep[i] = 0;
    }
  }
  return keep;
}

void StereoTracker::matchTracksInRight(const std::vector<cv::Mat>& left_pyramid,
                                       const std::vector<cv::Mat>& right_pyramid,
                                       const std::vector<float>& predicted_disparity,
                                       StereoMatchCounts* counts, TrackerFrameStats* stats) {
  if (tracks_.empty()) return;
  std::vector<cv::Point2f> left(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) left[i] = tracks_[i].left;
  std::vector<uint8_t> ok;
  const std::vector<cv::Point2f> right =
      matchStereo(left_pyramid, right_pyramid, left, predicted_disparity, options_, true,
                  masks_.right, &ok, counts);
  const bool check_disparity = has_last_motion_ && (options_.disparity_check_px > 0 ||
                                                    options_.disparity_check_relative > 0);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    if (!ok[i]) {
      ++stats->stereo_lost;
      continue;
    }
    const double predicted = predicted_disparity[i];
    const double measured = left[i].x - right[i].x;
    if (check_disparity &&
        std::abs(measured - predicted) >
            options_.disparity_check_px + options_.disparity_check_relative * predicted) {
      ++stats->disparity_rejected;
      ok[i] = 0;
      continue;
    }
    tracks_[i].right = right[i];
  }
  keepSelected(ok, &tracks_);
}

void StereoTracker::addNewTracks(const cv::Mat& left, const std::vector<cv::Mat>& left_pyramid,
                                 const std::vector<cv::Mat>& right_pyramid,
                                 const std::vector<cv::KeyPoint>* found, StereoMatchCounts* counts,
                                 TrackerFrameStats* stats) {
  auto t = Clock::now();
  std::vector<cv::Point2f> existing(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) existing[i] = tracks_[i].left;
  const std::vector<cv::Point2f> corners = detector_.detect(left, existing, masks_.left, found);
  stats->detected = static_cast<int>(corners.size());
  stats->ms_detect += msSince(t);

  t = Clock::now();
  const std::vector<float> seed(corners.size(), 0.f);
  std::vector<uint8_t> ok;
  const size_t tracks_in_frame = tracks_.size();
  // New features wait confirm_frames before they are published, and are matched anew then: their
  // stereo match is refined only when they are published at once.
  const bool refine = tracks_in_frame == 0 || options_.confirm_frames == 0;
  const std::vector<cv::Point2f> right = matchStereo(left_pyramid, right_pyramid, corners, seed,
                                                     options_, refine, masks_.right, &ok, counts);
  for (size_t i = 0; i < corners.size(); ++i) {
    if (!ok[i]) continue;
    Track track;
    // Without tracks to continue (first pair, after a loss or reset), publish at once.
    if (tracks_in_frame == 0) track.age = options_.confirm_frames;
    track.left = corners[i];
    track.right = right[i];
    if (options_.refine) setReference(left, &track);
    tracks_.push_back(std::move(track));
    ++stats->new_tracks;
  }
  stats->ms_stereo += msSince(t);
}

void StereoTracker::fillFrame(double stamp, StereoFrame* frame) {
  frame->stamp = stamp;
  frame->features.clear();
  frame->features.reserve(tracks_.size());
  for (Track& track : tracks_) {
    if (track.age < options_.confirm_frames) continue;
    if (!track.has_id) {
      track.id = next_id_++;
      track.has_id = true;
    }
    TrackedFeature feature;
    feature.id = track.id;
    feature.left = track.left;
    // The tracks keep the measured columns (the rig check fits the offset on them).
    feature.right = track.right + cv::Point2f(frame->stats.disparity_offset_corrected_px, 0.f);
    feature.age = track.age - options_.confirm_frames;
    feature.trail = track.trail;
    frame->features.push_back(std::move(feature));
  }
  frame->stats.published = static_cast<int>(frame->features.size());
}

}  // namespace ekf_vislam
