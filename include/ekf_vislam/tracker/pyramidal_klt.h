// Pyramidal Lucas-Kanade point tracking: OpenCV's algorithm (cv::calcOpticalFlowPyrLK with
// OPTFLOW_USE_INITIAL_FLOW: the same fixed-point bilinear windows, minimum-eigenvalue test,
// stopping rules and status), with each window row taken sixteen pixels at a time (AVX2) where
// OpenCV takes four and then one at a time. Sums are exact integers where OpenCV's are float, so
// a point may end a few thousandths of a pixel apart. Falls back to OpenCV where the fast path
// does not apply (no AVX2, windows wider than 15 px, pyramids without derivatives or without a
// wide enough border). No ROS.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace ekf_vislam {

/// KLT settings shared by the forward and the backward pass.
struct KltSettings {
  cv::Size window;
  int levels = 0;  ///< pyramid levels above the full image
  cv::TermCriteria criteria;
};

/// Tracks prev[i] (in the image of `prev_pyramid`) into the image of `next_pyramid`, starting at
/// (*next)[i]; both pyramids from cv::buildOpticalFlowPyramid with derivatives. Leaves the
/// result in *next and 1 in (*status)[i] where the point was tracked (0: it left the image or
/// its window had too little texture), as cv::calcOpticalFlowPyrLK with
/// OPTFLOW_USE_INITIAL_FLOW and its default minimum eigenvalue (1e-4) does.
void trackPyramidalKlt(const std::vector<cv::Mat>& prev_pyramid,
                       const std::vector<cv::Mat>& next_pyramid,
                       const std::vector<cv::Point2f>& prev, std::vector<cv::Point2f>* next,
                       std::vector<uint8_t>* status, const KltSettings& klt);

/// Whether trackPyramidalKlt takes its own path (not OpenCV's) for these pyramids and settings.
bool pyramidalKltFastPath(const std::vector<cv::Mat>& prev_pyramid,
                          const std::vector<cv::Mat>& next_pyramid, const KltSettings& klt);

}  // namespace ekf_vislam
