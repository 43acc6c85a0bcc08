#include "ekf_vislam/tracker/stereo_rig_check.h"

#include "ekf_vislam/core/median.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace ekf_vislam {

StereoRigCheck::StereoRigCheck(double row_tolerance_px, bool offset_corrected)
    : row_tolerance_px_(row_tolerance_px), offset_corrected_(offset_corrected) {}

void StereoRigCheck::add(const TrackerFrameStats& stats) {
  constexpr float kNone = std::numeric_limits<float>::quiet_NaN();
  const bool offset_told = stats.disparity_offset_sigma_px <= kMaxOffsetSigmaPx;
  const bool roll_told = stats.stereo_roll_sigma_deg <= kMaxRollSigmaDeg;
  pairs_.push_back(
      {stats.stereo_converged, stats.stereo_row_failed, stats.stereo_negative_disparity,
       stats.stereo_row_offset_px, offset_told ? stats.disparity_offset_px : kNone,
       roll_told ? stats.stereo_roll_deg : kNone, roll_told ? stats.stereo_roll_edge_px : kNone});
  if (pairs_.size() > static_cast<size_t>(kWindowPairs)) pairs_.pop_front();
  // The correction holds where no offset is fitted (a stop).
  if (!offset_told || disparityOffsetPairs() < kMinEarlyOffsetPairs) return;
  correcting_ = correcting_ || offsetBeyondHint();
  if (correcting_) correction_px_ = medianDisparityOffsetPx();
}

bool StereoRigCheck::offsetBeyondHint() const {
  std::vector<float> offsets = finiteValues(&Pair::disparity_offset_px);
  const int fits = static_cast<int>(offsets.size());
  if (fits < kMinEarlyOffsetPairs) return false;
  const double median_px = upperMedian(&offsets);
  const double beyond_px = std::abs(median_px) - kOffsetHintPx;
  if (fits >= kMinOffsetPairs) return beyond_px > 0;
  // Fewer fits: beyond by kEarlyOffsetSigmas standard errors of their median (1.253 sigma /
  // sqrt(n) for normal scatter), the scatter read from their median absolute deviation.
  for (float& offset : offsets) offset = static_cast<float>(std::abs(offset - median_px));
  const double scatter_px = std::max(1.4826 * upperMedian(&offsets), kMinOffsetScatterPx);
  return beyond_px > kEarlyOffsetSigmas * 1.253 * scatter_px / std::sqrt(fits);
}

void StereoRigCheck::reset() {
  pairs_.clear();
  correcting_ = false;
  correction_px_ = 0;
}

int StereoRigCheck::matchesHeld() const {
  int converged = 0;
  for (const Pair& pair : pairs_) converged += pair.converged;
  return converged;
}

double StereoRigCheck::rowFailedFraction() const {
  int row_failed = 0;
  for (const Pair& pair : pairs_) row_failed += pair.row_failed;
  const int converged = matchesHeld();
  return converged > 0 ? static_cast<double>(row_failed) / converged : 0.0;
}

double StereoRigCheck::negativeDisparityFraction() const {
  int on_row = 0, negative = 0;
  for (const Pair& pair : pairs_) {
    on_row += pair.converged - pair.row_failed;
    negative += pair.negative_disparity;
  }
  return on_row > 0 ? static_cast<double>(negative) / on_row : 0.0;
}

std::vector<float> StereoRigCheck::finiteValues(float Pair::*figure) const {
  std::vector<float> values;
  for (const Pair& pair : pairs_) {
    if (std::isfinite(pair.*figure)) values.push_back(pair.*figure);
  }
  return values;
}

double StereoRigCheck::medianOfFinite(float Pair::*figure) const {
  std::vector<float> values = finiteValues(figure);
  return values.empty() ? 0.0 : upperMedian(&values);
}

double StereoRigCheck::medianRowOffsetPx() const { return medianOfFinite(&Pair::row_offset_px); }

double StereoRigCheck::medianDisparityOffsetPx() const {
  return medianOfFinite(&Pair::disparity_offset_px);
}

int StereoRigCheck::disparityOffsetPairs() const { return countFinite(&Pair::disparity_offset_px); }

double StereoRigCheck::medianStereoRollDeg() const { return medianOfFinite(&Pair::roll_deg); }

double StereoRigCheck::medianRollEdgePx() const { return medianOfFinite(&Pair::roll_edge_px); }

int StereoRigCheck::stereoRollPairs() const { return countFinite(&Pair::roll_deg); }

int StereoRigCheck::countFinite(float Pair::*figure) const {
  return static_cast<int>(std::count_if(pairs_.begin(), pairs_.end(), [figure](const Pair& pair) {
    return std::isfinite(pair.*figure);
  }));
}

std::string StereoRigCheck::hint() const {
  if (matchesHeld() < kMinMatches) return "";
  char text[640];
  if (rowFailedFraction() > 0.5) {
    std::snprintf(text, sizeof(text),
                  "%.0f %% of the left-right matches lie further apart in rows than "
                  "stereo/row_tolerance_px (%.1f px; median row offset %.1f px): are the images "
                  "rectified (image_rect, not image_raw) and is the calibration the rig's own?",
                  100.0 * rowFailedFraction(), row_tolerance_px_, medianRowOffsetPx());
    return text;
  }
  if (negativeDisparityFraction() > 0.5) {
    std::snprintf(text, sizeof(text),
                  "%.0f %% of the left-right matches have negative disparity (the right image's "
                  "point right of the left one's): are the left and right images swapped?",
                  100.0 * negativeDisparityFraction());
    return text;
  }
  if (offsetBeyondHint()) {
    const double offset_px = medianDisparityOffsetPx();
    const int offset_pairs = disparityOffsetPairs();
    std::snprintf(
        text, sizeof(text),
        "the tracks' motion fits best with every measured disparity %.2f px %s the "
        "true one (median over %d pairs): the rectification or the right camera's principal "
        "point (cx in P of its camera_info) disagrees with its images, and every stereo depth "
        "%s too %s. %s",
        std::abs(offset_px), offset_px < 0 ? "below" : "above", offset_pairs,
        offset_corrected_ ? "would be" : "is", offset_px < 0 ? "large" : "small",
        offset_corrected_
            ? "The published disparities are corrected by it "
              "(stereo/correct_disparity_offset); recalibrating the rig is better"
            : "Recalibrate the rig, set stereo/correct_disparity_offset: true in the tracker's "
              "configuration, or intrinsic/estimate_disparity_offset: true in the estimator's");
    return text;
  }
  const double roll_deg = medianStereoRollDeg();
  const double roll_edge_px = medianRollEdgePx();
  const int roll_pairs = stereoRollPairs();
  if (roll_pairs >= kMinRollPairs &&
      std::abs(roll_edge_px) > kRollHintFraction * row_tolerance_px_) {
    std::snprintf(
        text, sizeof(text),
        "the right image is turned %.3f degrees %s (as displayed) against the left one (median "
        "over %d pairs): rows at the image's side edge lie %.2f px apart, where matches beyond "
        "stereo/row_tolerance_px (%.1f px) are lost, and disparities err in proportion to the "
        "distance from the middle row. The rectification (R and P of the camera_info) does not "
        "fit the rig: recalibrate it",
        std::abs(roll_deg), roll_deg > 0 ? "clockwise" : "anticlockwise", roll_pairs,
        std::abs(roll_edge_px), row_tolerance_px_);
    return text;
  }
  return "";
}

}  // namespace ekf_vislam
