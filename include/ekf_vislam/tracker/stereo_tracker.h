// Stereo feature tracker over rectified image pairs: grid corners, pyramidal KLT frame to frame
// with a forward-backward check, RANSAC over the temporal matches, a left-right KLT match on the
// same row, persistent ids (never reused). The heart of the stereo front end; no ROS.
#pragma once

#include "ekf_vislam/tracker/exposure_compensation.h"
#include "ekf_vislam/tracker/feature_detector.h"
#include "ekf_vislam/tracker/image_mask.h"
#include "ekf_vislam/tracker/motion_check.h"
#include "ekf_vislam/tracker/patch_refiner.h"
#include "ekf_vislam/tracker/stereo_matcher.h"
#include "ekf_vislam/tracker/stereo_rig_check.h"
#include "ekf_vislam/tracker/tracker_options.h"
#include "ekf_vislam/tracker/tracker_types.h"

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace ekf_vislam {

class StereoTracker {
 public:
  /// `options` must pass validate() and `calibration` must pass validate() (checked by the
  /// callers); `masks` (loadStereoMasks) keep features off parts of the images. Ids start at
  /// `first_id`: a tracker that replaces another (a new calibration) starts at its nextId(), so
  /// that no id is used twice.
  StereoTracker(const TrackerOptions& options, const StereoCalibration& calibration,
                StereoMasks masks = StereoMasks(), uint32_t first_id = 0);

  /// Processes one rectified pair (8-bit single channel, same size, that of the masks) taken at
  /// `stamp` (s). `prior` (optional) predicts the KLT start points. On bad input returns false,
  /// sets *why and leaves the tracks as they were. An image size different from the previous pair's
  /// ends all tracks (the pair is processed as a first frame).
  bool process(const cv::Mat& left, const cv::Mat& right, double stamp,
               const CameraMotionPrior* prior, StereoFrame* frame, std::string* why);

  /// Ends every track and forgets the rig check's pairs (the next pair starts afresh; ids
  /// continue).
  void reset();

  /// The rig check over the last pairs tracked (stereo_rig_check.h). With
  /// stereo/correct_disparity_offset, its disparityCorrectionPx() is added to every published
  /// right column (TrackerFrameStats::disparity_offset_corrected_px), and in the pair where it
  /// starts every published track goes on under a new id.
  const StereoRigCheck& rigCheck() const { return rig_check_; }

  /// The id the next published track gets.
  uint32_t nextId() const { return next_id_; }
  const StereoCalibration& calibration() const { return calibration_; }
  const TrackerOptions& options() const { return options_; }

 private:
  struct Track {
    uint32_t id = 0;  ///< valid once published
    bool has_id = false;
    cv::Point2f left, right;
    int age = 0;
    std::vector<cv::Point2f> trail;
    ReferencePatch reference;  ///< left patch the track is aligned to (refine/enabled)
    AffineWarp warp;           ///< the reference's warp into the last left image
  };

  // Why a pair cannot be tracked (empty: it can).
  std::string inputProblem(const cv::Mat& left, const cv::Mat& right, double stamp) const;
  // Each track's predicted left position, from the prior or the last motion (`used`); false when
  // there is neither (positions unchanged).
  bool predictLeft(const CameraMotionPrior* prior, double dt, CameraMotionPrior* used,
                   std::vector<cv::Point2f>* predicted) const;
  // What the tracks' KLT starts from: each track's point in the previous left image and its
  // predicted one in the new image (the previous pyramid is prev_left_pyramid_).
  struct TemporalStart {
    CameraMotionPrior prediction;  ///< the motion the start points were predicted with
    bool predicted = false;        ///< false: start points unchanged (no prior, no last motion)
    std::vector<cv::Point2f> prev, cur;
  };
  // Predicts the tracks' start points and brings the previous pyramid to the new left image's
  // exposure: needs the new image, not its pyramid.
  TemporalStart startTemporal(const cv::Mat& left, const CameraMotionPrior* prior, double dt,
                              TrackerFrameStats* stats);
  // KLT of the tracks into the new left image, forward-backward check, refinement, left mask
  // and RANSAC; drops the lost tracks and returns each survivor's predicted disparity (the
  // left-right KLT seed).
  std::vector<float> trackTemporal(TemporalStart start, const std::vector<cv::Mat>& left_pyramid,
                                   TrackerFrameStats* stats);
  // Rebuilds the previous left pyramid, in place, from the previous image brought to the new
  // one's exposure (klt/exposure_compensation; a map fitted on the tracks `prev` -> `cur`);
  // unchanged when off or without a map. Its time counts as the pyramids'.
  void bringPreviousPyramidToExposure(const cv::Mat& left, const std::vector<cv::Point2f>& prev,
                                      const std::vector<cv::Point2f>& cur,
                                      TrackerFrameStats* stats);
  // KLT from `prev` (start points *cur) into the new left image and the forward-backward check:
  // the tracks lost or outside the image border end (with their points in *prev, *cur).
  void followTracks(const std::vector<cv::Mat>& prev_pyramid,
                    const std::vector<cv::Mat>& left_pyramid, bool predicted,
                    std::vector<cv::Point2f>* prev, std::vector<cv::Point2f>* cur,
                    TrackerFrameStats* stats);
  // Without a prior or a last motion (the second pair without a twist) every KLT would start
  // where its track was, and a fast or turning camera loses many tracks there. So up to 100 tracks
  // spread over the list are tracked first (KLT and back-check), their motion fitted by the
  // RANSAC, and every start point predicted from it. Returns false (start unchanged) when no
  // motion was found.
  bool predictFromFirstMatches(const std::vector<cv::Mat>& prev_pyramid,
                               const std::vector<cv::Mat>& left_pyramid,
                               TemporalStart* start) const;
  // Ends the tracks whose `keep` is 0, with their points in *prev and *cur.
  void keepTracks(const std::vector<uint8_t>& keep, std::vector<cv::Point2f>* prev,
                  std::vector<cv::Point2f>* cur);
  // RANSAC over the temporal matches (the tracks' previous stereo points against `cur`): the
  // outliers end; the survivors move to `cur` and get their predicted disparity (returned) from
  // the estimated motion, else `prediction`.
  std::vector<float> checkMotion(const std::vector<cv::Point2f>& prev,
                                 const std::vector<cv::Point2f>& cur,
                                 const CameraMotionPrior& prediction, TrackerFrameStats* stats);
  // The rig's disparity offset fitted with the motion the check found (disparity_offset_fit.h),
  // from every track's previous stereo match and `cur`, into *stats.
  void fitRigDisparityOffset(const std::vector<cv::Point2f>& cur, const MotionCheckResult& check,
                             TrackerFrameStats* stats) const;
  // Ends each track that has come within half of detector/min_feature_distance of an older one
  // (the tracks are kept oldest first), with its predicted disparity.
  void endCrowdedTracks(std::vector<float>* predicted_disparity, TrackerFrameStats* stats);
  // Aligns each track's reference patch to `left` from its KLT position in *cur and moves it
  // there. Where that fails, the KLT position stands and the reference is taken anew (also when
  // the warp scaled it too much), or with refine/end_failed_tracks the track is to end: returns
  // which tracks to keep.
  std::vector<uint8_t> refineLeft(const cv::Mat& left, std::vector<cv::Point2f>* cur,
                                  TrackerFrameStats* stats);
  void setReference(const cv::Mat& left, Track* track) const;
  // The right pyramid, from the right image brought to the left one's exposure (the stereo map
  // refitted on the tracks at their predicted disparities, klt/exposure_compensation). Its time
  // counts as the pyramids'.
  void buildRightPyramid(const cv::Mat& left, const cv::Mat& right,
                         const std::vector<float>& predicted_disparity, int levels,
                         TrackerFrameStats* stats);
  // Fits stereo_exposure_ (right image to left) on the tracks and their predicted right points.
  void updateStereoExposure(const cv::Mat& left, const cv::Mat& right,
                            const std::vector<float>& predicted_disparity);
  void matchTracksInRight(const std::vector<cv::Mat>& left_pyramid,
                          const std::vector<cv::Mat>& right_pyramid,
                          const std::vector<float>& predicted_disparity, StereoMatchCounts* counts,
                          TrackerFrameStats* stats);
  // New corners (from `found`, the left image's corners computed beforehand, or searched now
  // when null) matched in the right image become new tracks.
  void addNewTracks(const cv::Mat& left, const std::vector<cv::Mat>& left_pyramid,
                    const std::vector<cv::Mat>& right_pyramid,
                    const std::vector<cv::KeyPoint>* found, StereoMatchCounts* counts,
                    TrackerFrameStats* stats);
  // Adds the pair to the rig check and, with stereo/correct_disparity_offset, sets the correction
  // fillFrame applies; where it starts, the published tracks get new ids (ids_renewed).
  void correctDisparityOffset(TrackerFrameStats* stats);
  cv::Point3f pointOf(const Track& track) const;
  void fillFrame(double stamp, StereoFrame* frame);

  TrackerOptions options_;
  StereoCalibration calibration_;
  StereoMasks masks_;
  GridFeatureDetector detector_;
  std::vector<Track> tracks_;
  // The pyramids live from frame to frame, so that each frame builds them into the memory of the
  // last: the new left one becomes the previous one by a swap, and the previous one is brought to
  // the new exposure in place.
  std::vector<cv::Mat> left_pyramid_, right_pyramid_, prev_left_pyramid_;
  cv::Size image_size_;
  double prev_stamp_ = 0;
  bool has_prev_ = false;
  uint32_t next_id_ = 0;
  // Motion of the last frame (for the next frame's KLT prediction) and its time step.
  bool has_last_motion_ = false;
  CameraMotionPrior last_motion_;
  double last_dt_ = 0;
  // klt/exposure_compensation: the map from the right image's intensities to the left's.
  IntensityMap stereo_exposure_;
  StereoRigCheck rig_check_;
};

}  // namespace ekf_vislam
