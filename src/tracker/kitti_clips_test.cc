// Track quality on the two real KITTI clips (../shared/data/kitti_clips or
// $EKF_VISLAM_DATA/kitti_clips); skipped when they are absent. The targets are: median
// left-image reprojection error of tracks triangulated at their first frame with the
// ground-truth pose <= 0.5 / 0.8 / 1.5 px at ages 1 / 2 / 5, >= 150 observations in every frame,
// mean track length >= 6 frames. They are NOT all met on the whole clips (doc/tracker.md,
// "Track quality"): where not, the bounds below are today's figures plus a small margin, so that
// a regression fails. The 06 ground truth disagrees with its images in its first second (frames
// 0-10, up to 0.17 degrees of yaw per frame); from frame 12 on, the error targets themselves are
// asserted. The stereo rig check must name the 01 clip's disparity offset (1.08 px by the
// tracker's fit, 1.39 px by the ground truth), and the tracker take it out of the published
// features (stereo/correct_disparity_offset), but not the 06 clip's (0.29 px; 0.23). It reads
// the right images' roll against the left ones (the rows' slope across the image; a made roll
// follows: doc/tracker.md) within bounds of its figures and warns of neither.
#include "ekf_vislam/core/yaml_parameter_source.h"
#include "ekf_vislam/tracker/kitti_sequence.h"
#include "ekf_vislam/tracker/stereo_rig_check.h"
#include "ekf_vislam/tracker/stereo_tracker.h"
#include "ekf_vislam/tracker/track_quality.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>

namespace ekf_vislam {
namespace {

std::string clipsFolder() {
  const char* env = std::getenv("EKF_VISLAM_DATA");
  if (env != nullptr) return std::string(env) + "/kitti_clips";
  // The source folder may be a folder of links to the repository's entries: resolve one.
  std::error_code ec;
  const std::filesystem::path repo =
      std::filesystem::canonical(std::string(EKF_VISLAM_SOURCE_DIR) + "/config", ec).parent_path();
  return (repo / ".." / "shared" / "data" / "kitti_clips").string();
}

struct ClipBounds {
  const char* folder;
  size_t first_frame;  // frames before it are left out
  // Measured ages 1 / 2 / 5: 0.660 / 1.163 / 2.713 px (06) at 958738e built on an Intel Xeon,
  // 0.656 / 1.178 / 2.702 px at 11a40a8 built on an AMD EPYC (the figures move with the build's
  // rounding); 01 0.524 / 0.816 / 1.910 px with its offset taken out of the published features
  // from its frame 3 on, where its tracks go on under new ids (0.586 / 0.930 / 2.111 px from its
  // frame 10 on; 0.967 / 1.809 / 4.395 px not taken out, at 958738e).
  double age1_px, age2_px, age5_px;
  int min_observations;        // measured 171 (06), 153 (01, its second pair: 142 before that
                               // pair's motion was fitted first)
  double mean_track_length;    // measured 3.92 (06), 5.26 (01: 5.56 before its tracks went on
                               // under new ids at its correction's start); 3.91, 5.47 at 11a40a8
                               // on the AMD EPYC. The 01 length moves with any change to the set
                               // of tracks: 5.33-5.99 over the tracker changes measured, 5.34-5.63
                               // with eight settings moved in their fourth digit (so its bound
                               // is 0.26 below the figure)
  bool disparity_offset_hint;  // the rig check's median offset: measured -0.286 px (06), -1.076
                               // (01), -0.285 (06 from frame 12). Corrected: 01 only
  // The rig check's median roll of the right image, degrees: measured -0.0148 (06), -0.0463
  // (01; rows 0.51 px apart at the side edge, where 0.75 px warns), -0.0149 (06 from frame 12).
  // A slope of the published tracks' own rows, fitted apart (without the KLT's other matches),
  // gives -0.027 and -0.061.
  double min_roll_deg, max_roll_deg;
};

const ClipBounds kClips[] = {
    {"odometry_06_000000-000050", 0, 0.75, 1.35, 3.05, 150, 3.7, false, -0.025, -0.005},
    {"odometry_01_000000-000050", 0, 0.60, 0.93, 2.20, 145, 5.0, true, -0.056, -0.036},
    // Measured 0.440 / 0.729 / 1.465 px, at least 168 observations, 3.78 frames (0.439 / 0.732 /
    // 1.466 px at 11a40a8 on the AMD EPYC; 1.465-1.493 px at age 5 with settings moved in their
    // fourth digit).
    {"odometry_06_000000-000050", 12, 0.5, 0.8, 1.5, 150, 3.5, false, -0.025, -0.005},
};

class KittiClips : public ::testing::TestWithParam<ClipBounds> {};

TEST_P(KittiClips, TrackQualityAgainstGroundTruth) {
  const ClipBounds& bounds = GetParam();
  const std::string folder = clipsFolder() + "/" + bounds.folder;
  if (!std::filesystem::is_directory(folder)) {
    GTEST_SKIP() << folder << " not found (set EKF_VISLAM_DATA): real-clip test skipped";
  }
  KittiSequence sequence;
  std::string error;
  ASSERT_TRUE(loadKittiSequence(folder + "/image_left", folder + "/image_right",
                                folder + "/calib.txt", folder + "/times.txt", folder + "/poses.txt",
                                &sequence, &error))
      << error;
  sequence.dropFirstFrames(bounds.first_frame);
  TrackerOptions options;
  YamlParameterSource source(std::string(EKF_VISLAM_SOURCE_DIR) + "/config/tracker.yaml");
  ASSERT_TRUE(source.ok() && parseTrackerOptions(source, &options, &error)) << error;
  StereoTracker tracker(options, sequence.calibration);
  const StereoRigCheck& rig_check = tracker.rigCheck();
  int frames_corrected = 0;
  std::vector<StereoFrame> frames(sequence.size());
  for (size_t k = 0; k < sequence.size(); ++k) {
    const cv::Mat left = cv::imread(sequence.left_images[k], cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(sequence.right_images[k], cv::IMREAD_GRAYSCALE);
    ASSERT_TRUE(tracker.process(left, right, sequence.times[k], nullptr, &frames[k], &error))
        << error;
    frames_corrected += frames[k].stats.disparity_offset_corrected_px != 0;
  }
  const TrackQuality quality =
      evaluateTrackQuality(frames, sequence.world_T_cam, sequence.calibration, 5);
  std::printf("%s from frame %zu: %s\n", bounds.folder, bounds.first_frame,
              quality.describe().c_str());
  EXPECT_LE(quality.median_error_px.at(1), bounds.age1_px);
  EXPECT_LE(quality.median_error_px.at(2), bounds.age2_px);
  EXPECT_LE(quality.median_error_px.at(5), bounds.age5_px);
  EXPECT_GE(quality.min_observations_per_frame, bounds.min_observations);
  EXPECT_GE(quality.mean_track_length, bounds.mean_track_length);
  EXPECT_GE(quality.mean_observations_per_frame, 150.0);
  std::printf("disparity offset %.3f px (median of %d fits)\n", rig_check.medianDisparityOffsetPx(),
              rig_check.disparityOffsetPairs());
  EXPECT_GE(rig_check.disparityOffsetPairs(), 30);
  EXPECT_EQ(std::abs(rig_check.medianDisparityOffsetPx()) > StereoRigCheck::kOffsetHintPx,
            bounds.disparity_offset_hint);
  EXPECT_EQ(rig_check.hint().empty(), !bounds.disparity_offset_hint) << rig_check.hint();
  // Corrected from the frame the check first warns (01: frame 3, its third fit, so 48 frames) to
  // the end, by the last median.
  std::printf("published disparities corrected in %d frames\n", frames_corrected);
  if (bounds.disparity_offset_hint) {
    EXPECT_GE(frames_corrected, 45);
  } else {
    EXPECT_EQ(frames_corrected, 0);
  }
  EXPECT_EQ(frames.back().stats.disparity_offset_corrected_px,
            static_cast<float>(rig_check.disparityCorrectionPx()));
  std::printf(
      "right image's roll %.4f degrees (median of %d fits; rows %.2f px apart at the "
      "side edge)\n",
      rig_check.medianStereoRollDeg(), rig_check.stereoRollPairs(), rig_check.medianRollEdgePx());
  EXPECT_EQ(rig_check.stereoRollPairs(),
            std::min<int>(static_cast<int>(sequence.size()), StereoRigCheck::kWindowPairs));
  EXPECT_GE(rig_check.medianStereoRollDeg(), bounds.min_roll_deg);
  EXPECT_LE(rig_check.medianStereoRollDeg(), bounds.max_roll_deg);
  EXPECT_LT(std::abs(rig_check.medianRollEdgePx()),
            StereoRigCheck::kRollHintFraction * options.row_tolerance_px);
}

INSTANTIATE_TEST_SUITE_P(Real, KittiClips, ::testing::ValuesIn(kClips));

}  // namespace
}  // namespace ekf_vislam
