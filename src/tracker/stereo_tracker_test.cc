#include "ekf_vislam/tracker/stereo_tracker.h"
#include "ekf_vislam/tracker/rectified_stereo.h"
#include "ekf_vislam/tracker/stereo_rig_check.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <utility>

namespace ekf_vislam {
namespace {

// A rectified stereo rig looking along +z at a textured plane z = depth + slope * x (world
// frame = left camera frame of the first pair), rendered by ray-plane intersection.
class SlantedPlaneScene {
 public:
  SlantedPlaneScene() {
    cv::Mat noise(1024, 2048, CV_32F);
    cv::RNG rng(7);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
    cv::GaussianBlur(noise, texture_, cv::Size(0, 0), 2.0);
    cv::normalize(texture_, texture_, 0, 255, cv::NORM_MINMAX);
  }
  const StereoCalibration& calibration() const { return calibration_; }
  cv::Size size() const { return cv::Size(640, 240); }

  /// Image of a camera at `position` (axes parallel to the world's) plus `x_offset` along x.
  cv::Mat render(const cv::Vec3d& position, double x_offset) const {
    cv::Mat map_x(size(), CV_32F), map_y(size(), CV_32F);
    const double cx = position[0] + x_offset;
    for (int v = 0; v < size().height; ++v) {
      for (int u = 0; u < size().width; ++u) {
        const double dx = (u - calibration_.cx) / calibration_.fx;
        const double dy = (v - calibration_.cy) / calibration_.fy;
        const double s = (depth_ + slope_ * cx - position[2]) / (1.0 - slope_ * dx);
        const double x = cx + s * dx, y = position[1] + s * dy;
        map_x.at<float>(v, u) = static_cast<float>(x * kTexturePerMetre + 1024);
        map_y.at<float>(v, u) = static_cast<float>(y * kTexturePerMetre + 512);
      }
    }
    cv::Mat image;
    cv::remap(texture_, image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REFLECT);
    image.convertTo(image, CV_8U);
    return image;
  }

  /// The world point seen at left pixel (u, v) by a camera at `position`.
  cv::Vec3d pointAt(const cv::Vec3d& position, double u, double v) const {
    const double dx = (u - calibration_.cx) / calibration_.fx;
    const double dy = (v - calibration_.cy) / calibration_.fy;
    const double s = (depth_ + slope_ * position[0] - position[2]) / (1.0 - slope_ * dx);
    return cv::Vec3d(position[0] + s * dx, position[1] + s * dy, position[2] + s);
  }
  cv::Point2d project(const cv::Vec3d& position, const cv::Vec3d& p_world) const {
    const cv::Vec3d p = p_world - position;
    return cv::Point2d(calibration_.fx * p[0] / p[2] + calibration_.cx,
                       calibration_.fy * p[1] / p[2] + calibration_.cy);
  }

 private:
  static constexpr double kTexturePerMetre = 60.0;
  double depth_ = 8.0, slope_ = 0.3;
  StereoCalibration calibration_ = rectifiedPair(400, 400, 320, 120, 0.5);
  cv::Mat texture_;
};

cv::Vec3d positionAt(int k) { return cv::Vec3d(0.04 * k, 0.01 * k, 0.15 * k); }

TEST(StereoTracker, IdsPersistAndPositionsFollowTheTrueMotion) {
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  std::map<uint32_t, cv::Vec3d> first_point;  // id -> world point at its first observation
  std::map<uint32_t, int> seen;
  int frames_with_many = 0;
  double max_position_error = 0, max_disparity_error = 0;
  std::vector<double> position_errors;
  const int num_frames = 12;
  for (int k = 0; k < num_frames; ++k) {
    const cv::Vec3d c = positionAt(k);
    StereoFrame frame;
    std::string why;
    ASSERT_TRUE(
        tracker.process(scene.render(c, 0), scene.render(c, 0.5), 0.1 * k, nullptr, &frame, &why))
        << why;
    if (frame.features.size() >= 100) ++frames_with_many;
    for (const TrackedFeature& f : frame.features) {
      ++seen[f.id];
      auto it = first_point.find(f.id);
      if (it == first_point.end()) {
        EXPECT_EQ(f.age, 0);
        first_point[f.id] = scene.pointAt(c, f.left.x, f.left.y);
        continue;
      }
      const cv::Point2d truth = scene.project(c, it->second);
      const double error = std::hypot(truth.x - f.left.x, truth.y - f.left.y);
      position_errors.push_back(error);
      max_position_error = std::max(max_position_error, error);
      // Disparity of the true point at the current pose.
      const cv::Vec3d p = it->second - c;
      const double disparity = scene.calibration().fx * scene.calibration().baseline / p[2];
      max_disparity_error =
          std::max(max_disparity_error, std::abs(disparity - (f.left.x - f.right.x)));
    }
  }
  EXPECT_EQ(frames_with_many, num_frames);
  // Most tracks started in the first frame live through all frames, with their ids.
  int full_length = 0;
  for (const auto& [id, count] : seen) full_length += count == num_frames;
  EXPECT_GE(full_length, 100);
  std::sort(position_errors.begin(), position_errors.end());
  EXPECT_LT(position_errors[position_errors.size() / 2], 0.25);
  EXPECT_LT(max_position_error, 2.0);
  EXPECT_LT(max_disparity_error, 1.0);
}

// Median left-image error of the tracks of age >= 3 (frames since publication) over 12 frames
// of the slanted plane, each track against the true image of the point it was published on.
double medianDriftOverTwelveFrames(const TrackerOptions& options) {
  SlantedPlaneScene scene;
  StereoTracker tracker(options, scene.calibration());
  std::map<uint32_t, cv::Vec3d> first_point;
  std::vector<double> errors;
  for (int k = 0; k < 12; ++k) {
    const cv::Vec3d c = positionAt(k);
    StereoFrame frame;
    std::string why;
    EXPECT_TRUE(
        tracker.process(scene.render(c, 0), scene.render(c, 0.5), 0.1 * k, nullptr, &frame, &why));
    for (const TrackedFeature& f : frame.features) {
      auto it = first_point.find(f.id);
      if (it == first_point.end()) {
        first_point[f.id] = scene.pointAt(c, f.left.x, f.left.y);
      } else if (f.age >= 3) {
        const cv::Point2d truth = scene.project(c, it->second);
        errors.push_back(std::hypot(truth.x - f.left.x, truth.y - f.left.y));
      }
    }
  }
  EXPECT_GE(errors.size(), 500u);
  std::sort(errors.begin(), errors.end());
  return errors.empty() ? 1e9 : errors[errors.size() / 2];
}

TEST(StereoTracker, RefinementAgainstTheFirstPatchRemovesTheKltDrift) {
  TrackerOptions plain;
  plain.refine = false;
  const double klt = medianDriftOverTwelveFrames(plain);
  const double refined = medianDriftOverTwelveFrames(TrackerOptions());
  std::printf("median drift at ages >= 3: KLT only %.4f px, refined %.4f px\n", klt, refined);
  EXPECT_LT(refined, 0.5 * klt);
  EXPECT_LT(refined, 0.05);
}

TEST(StereoTracker, DisparityMatchesDepth) {
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  StereoFrame frame;
  std::string why;
  const cv::Vec3d c(0, 0, 0);
  ASSERT_TRUE(tracker.process(scene.render(c, 0), scene.render(c, 0.5), 0, nullptr, &frame, &why));
  ASSERT_GE(frame.features.size(), 100u);
  std::vector<double> errors;
  for (const TrackedFeature& f : frame.features) {
    const cv::Vec3d p = scene.pointAt(c, f.left.x, f.left.y);
    const double disparity = scene.calibration().fx * 0.5 / p[2];
    errors.push_back(std::abs(disparity - (f.left.x - f.right.x)));
    EXPECT_LT(std::abs(f.right.y - f.left.y), 0.5);
  }
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.05);
  EXPECT_LT(errors.back(), 0.5);
}

// The first pair's left-right figures (TrackerFrameStats) for a left and a right image.
TrackerFrameStats firstPairStats(const SlantedPlaneScene& scene, const cv::Mat& left,
                                 const cv::Mat& right) {
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  StereoFrame frame;
  std::string why;
  EXPECT_TRUE(tracker.process(left, right, 0, nullptr, &frame, &why)) << why;
  return frame.stats;
}

std::string rigHint(const TrackerFrameStats& stats) {
  StereoRigCheck check(TrackerOptions().row_tolerance_px);
  check.add(stats);
  return check.hint();
}

TEST(StereoTracker, LeftRightMatchesShowAnUnrectifiedOrASwappedRig) {
  SlantedPlaneScene scene;
  const cv::Vec3d c(0, 0, 0);
  const cv::Mat left = scene.render(c, 0), right = scene.render(c, 0.5);
  const TrackerFrameStats rectified = firstPairStats(scene, left, right);
  ASSERT_GE(rectified.stereo_converged, 200);
  EXPECT_LT(std::abs(rectified.stereo_row_offset_px), 0.1);
  // Corners the KLT drags off their row (this slanted texture: about 30 %; the KITTI clips
  // 21 %, the rendered drive 0.3 %) stay well below half.
  EXPECT_LT(rectified.stereo_row_failed, 0.4 * rectified.stereo_converged);
  EXPECT_LT(rectified.stereo_negative_disparity, 0.05 * rectified.stereo_converged);
  EXPECT_EQ(rigHint(rectified), "");

  // The right image 3 rows lower than the left: a rig not rectified (or rectified wrongly).
  cv::Mat right_lower;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 0, 0, 1, 3);
  cv::warpAffine(right, right_lower, shift, right.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const TrackerFrameStats lower = firstPairStats(scene, left, right_lower);
  ASSERT_GE(lower.stereo_converged, 200);
  EXPECT_NEAR(lower.stereo_row_offset_px, 3.0, 0.2);
  EXPECT_GT(lower.stereo_row_failed, 0.8 * lower.stereo_converged);
  EXPECT_EQ(lower.new_tracks, 0);
  EXPECT_NE(rigHint(lower).find("rectified"), std::string::npos) << rigHint(lower);

  // Left and right swapped: every point lies right of its left position.
  const TrackerFrameStats swapped = firstPairStats(scene, right, left);
  const int on_row = swapped.stereo_converged - swapped.stereo_row_failed;
  ASSERT_GE(on_row, 200);
  EXPECT_GT(swapped.stereo_negative_disparity, 0.8 * on_row);
  EXPECT_NE(rigHint(swapped).find("swapped"), std::string::npos) << rigHint(swapped);
}

TEST(StereoTracker, IdsAreNeverReusedAndLostTracksEnd) {
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  std::map<uint32_t, int> last_frame;
  std::string why;
  for (int k = 0; k < 6; ++k) {
    // Frame 3 jumps far: the old tracks are lost, new ids start.
    const cv::Vec3d c = k < 3 ? positionAt(k) : positionAt(k) + cv::Vec3d(3.0, 0, 0);
    StereoFrame frame;
    ASSERT_TRUE(
        tracker.process(scene.render(c, 0), scene.render(c, 0.5), k, nullptr, &frame, &why));
    for (const TrackedFeature& f : frame.features) {
      if (last_frame.count(f.id)) {
        EXPECT_EQ(last_frame[f.id], k - 1) << "id " << f.id << " reused";
      }
      last_frame[f.id] = k;
    }
  }
}

// The fraction of a frame's features still published in the next (mean over 5 steps) when every
// left image is brighter or darker than the last (automatic exposure) and the right camera has a
// lower gain.
double keptUnderExposureChanges(bool compensate) {
  SlantedPlaneScene scene;
  TrackerOptions options;
  options.exposure_compensation = compensate;
  StereoTracker tracker(options, scene.calibration());
  const double gains[] = {1.0, 1.3, 0.9, 1.25, 0.8, 1.1};
  double kept = 0, published = 0;
  std::string why;
  for (int k = 0; k < 6; ++k) {
    const cv::Vec3d c = positionAt(k);
    cv::Mat left, right;
    scene.render(c, 0).convertTo(left, CV_8U, gains[k], 10);
    scene.render(c, 0.5).convertTo(right, CV_8U, 0.75 * gains[k], 20);
    StereoFrame frame;
    EXPECT_TRUE(tracker.process(left, right, k, nullptr, &frame, &why)) << why;
    const auto continuing = std::count_if(frame.features.begin(), frame.features.end(),
                                          [](const TrackedFeature& f) { return f.age > 0; });
    if (k > 0) kept += static_cast<double>(continuing) / published / 5;
    published = static_cast<double>(frame.features.size());
  }
  return kept;
}

TEST(StereoTracker, ExposureCompensationKeepsTracksThroughBrightnessChanges) {
  const double with = keptUnderExposureChanges(true), without = keptUnderExposureChanges(false);
  std::printf("tracks kept per frame: %.3f compensated, %.3f not\n", with, without);
  EXPECT_GE(with, 0.9);
  EXPECT_LT(without, 0.8);  // the case is a hard one for the KLT alone
}

// Published features over 6 frames of the slanted plane, whose image flows away from the focus
// of expansion (u = 427): left of it, towards the left border.
std::vector<TrackedFeature> publishedOverSixFrames(const StereoMasks& masks) {
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration(), masks);
  std::vector<TrackedFeature> published;
  std::string why;
  for (int k = 0; k < 6; ++k) {
    const cv::Vec3d c = positionAt(k);
    StereoFrame frame;
    EXPECT_TRUE(tracker.process(scene.render(c, 0), scene.render(c, 0.5), k, nullptr, &frame, &why))
        << why;
    published.insert(published.end(), frame.features.begin(), frame.features.end());
  }
  return published;
}

TEST(StereoTracker, MasksKeepFeaturesOffMaskedPixels) {
  // Columns below 200 masked: in the left image they hold no corner and the tracks that flow
  // into them end; in the right image no stereo match lands there. One image masked at a time.
  cv::Mat mask(240, 640, CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(0, 0, 200, 240)).setTo(0);
  const auto masked_left = [](const TrackedFeature& f) { return cvRound(f.left.x) < 200; };
  const auto masked_right = [](const TrackedFeature& f) { return cvRound(f.right.x) < 200; };
  const auto count = [](const std::vector<TrackedFeature>& features, const auto& predicate) {
    return std::count_if(features.begin(), features.end(), predicate);
  };
  const std::vector<TrackedFeature> free = publishedOverSixFrames(StereoMasks());
  ASSERT_GT(count(free, masked_left), 100);
  ASSERT_GT(
      count(free, [&](const TrackedFeature& f) { return !masked_left(f) && masked_right(f); }), 10);
  // Tracks that begin right of the mask and flow into it over the frames.
  std::map<uint32_t, int> entering;
  for (const TrackedFeature& f : free) {
    if (!masked_left(f)) entering.emplace(f.id, 0);
  }
  ASSERT_GT(count(free,
                  [&](const TrackedFeature& f) {
                    return masked_left(f) && entering.count(f.id) && f.age > 0;
                  }),
            10);

  const std::vector<TrackedFeature> left_masked = publishedOverSixFrames({mask, cv::Mat()});
  EXPECT_GT(left_masked.size(), 0.5 * free.size());
  EXPECT_EQ(count(left_masked, masked_left), 0);
  const std::vector<TrackedFeature> right_masked = publishedOverSixFrames({cv::Mat(), mask});
  EXPECT_GT(right_masked.size(), 0.5 * free.size());
  EXPECT_EQ(count(right_masked, masked_right), 0);

  // A mask of another size than the images: every pair is refused, naming the key.
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration(),
                        {cv::Mat(376, 1241, CV_8UC1, cv::Scalar(255)), mask});
  StereoFrame frame;
  std::string why;
  EXPECT_FALSE(tracker.process(scene.render(positionAt(0), 0), scene.render(positionAt(0), 0.5),
                               0.0, nullptr, &frame, &why));
  EXPECT_EQ(why, "the 'mask/left' image is 1241x376, the camera images 640x240");
}

TEST(StereoTracker, IndependentlyMovingPatchIsRejected) {
  // The right third of both images slides 6 px down per frame relative to the scene: its KLT
  // matches are consistent in themselves but not with the camera motion.
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  std::string why;
  int rejected = 0;
  int moving_published = 0;
  for (int k = 0; k < 4; ++k) {
    const cv::Vec3d c = positionAt(k);
    cv::Mat left = scene.render(c, 0), right = scene.render(c, 0.5);
    const cv::Rect patch(420, 60, 120, 120);
    const cv::Vec3d shifted = c + cv::Vec3d(0, -0.15 * k, 0);
    scene.render(shifted, 0)(patch).copyTo(left(patch));
    scene.render(shifted, 0.5)(patch).copyTo(right(patch));
    StereoFrame frame;
    ASSERT_TRUE(tracker.process(left, right, k, nullptr, &frame, &why));
    if (k == 0) continue;
    rejected += frame.stats.ransac_rejected;
    for (const TrackedFeature& f : frame.features) {
      if (f.age > 0 && patch.contains(cv::Point(f.left)) && f.left.x > 440 && f.left.x < 520 &&
          f.left.y > 80 && f.left.y < 160) {
        ++moving_published;
      }
    }
  }
  EXPECT_GE(rejected, 5);
  EXPECT_EQ(moving_published, 0);
}

TEST(StereoTracker, RefusesBadInputWithoutLosingTracks) {
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  StereoFrame frame;
  std::string why;
  const cv::Mat left = scene.render(positionAt(0), 0), right = scene.render(positionAt(0), 0.5);
  ASSERT_TRUE(tracker.process(left, right, 1.0, nullptr, &frame, &why));
  const size_t n = frame.features.size();
  StereoFrame bad;
  EXPECT_FALSE(
      tracker.process(left, right(cv::Rect(0, 0, 320, 240)).clone(), 2.0, nullptr, &bad, &why));
  cv::Mat color;
  cv::cvtColor(left, color, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(tracker.process(color, right, 2.0, nullptr, &bad, &why));
  EXPECT_FALSE(tracker.process(left, right, 1.0, nullptr, &bad, &why));  // not after 1.0
  EXPECT_FALSE(tracker.process(cv::Mat(), right, 2.0, nullptr, &bad, &why));
  const cv::Vec3d c = positionAt(1);
  ASSERT_TRUE(
      tracker.process(scene.render(c, 0), scene.render(c, 0.5), 2.0, nullptr, &frame, &why));
  int old = 0;
  for (const TrackedFeature& f : frame.features) old += f.age == 1;
  EXPECT_GE(old, static_cast<int>(0.8 * n));
}

// The tracker keeps its pyramids' memory from pair to pair. After the image size changes, the
// tracks restart and the pairs of the new size are tracked as a new tracker tracks them.
TEST(StereoTracker, AfterASizeChangeTracksAsANewTracker) {
  SlantedPlaneScene scene;
  TrackerOptions options;
  options.exposure_compensation = false;  // its stereo map is kept through a restart, by design
  StereoTracker resized(options, scene.calibration()), fresh(options, scene.calibration());
  StereoFrame frame, fresh_frame;
  std::string why;
  for (int k = 0; k < 3; ++k) {
    const cv::Vec3d c = positionAt(k);
    ASSERT_TRUE(
        resized.process(scene.render(c, 0), scene.render(c, 0.5), k, nullptr, &frame, &why));
  }
  const cv::Rect crop(0, 0, 480, 200);  // from the origin: the calibration still holds
  for (int k = 3; k < 6; ++k) {
    SCOPED_TRACE(k);
    const cv::Vec3d c = positionAt(k);
    const cv::Mat left = scene.render(c, 0)(crop).clone(),
                  right = scene.render(c, 0.5)(crop).clone();
    ASSERT_TRUE(resized.process(left, right, k, nullptr, &frame, &why));
    ASSERT_TRUE(fresh.process(left, right, k, nullptr, &fresh_frame, &why));
    ASSERT_EQ(frame.features.size(), fresh_frame.features.size());
    ASSERT_GT(frame.features.size(), 50u);
    for (size_t i = 0; i < frame.features.size(); ++i) {
      EXPECT_EQ(frame.features[i].left, fresh_frame.features[i].left) << i;
      EXPECT_EQ(frame.features[i].right, fresh_frame.features[i].right) << i;
      EXPECT_EQ(frame.features[i].age, fresh_frame.features[i].age) << i;
    }
  }
}

// A tracker built to replace another (the node does so for a new calibration) starts its ids
// where the other's would have gone on.
TEST(StereoTracker, AReplacingTrackerContinuesTheIds) {
  SlantedPlaneScene scene;
  StereoTracker first(TrackerOptions(), scene.calibration());
  StereoFrame frame;
  std::string why;
  uint32_t largest = 0;
  for (int k = 0; k < 3; ++k) {
    const cv::Vec3d c = positionAt(k);
    ASSERT_TRUE(first.process(scene.render(c, 0), scene.render(c, 0.5), k, nullptr, &frame, &why));
    for (const TrackedFeature& f : frame.features) largest = std::max(largest, f.id);
  }
  ASSERT_GT(frame.features.size(), 100u);
  EXPECT_EQ(first.nextId(), largest + 1);
  StereoTracker second(TrackerOptions(), scene.calibration(), StereoMasks(), first.nextId());
  const cv::Vec3d c = positionAt(3);
  ASSERT_TRUE(second.process(scene.render(c, 0), scene.render(c, 0.5), 3, nullptr, &frame, &why));
  ASSERT_GT(frame.features.size(), 100u);
  for (const TrackedFeature& f : frame.features) EXPECT_GT(f.id, largest);
}

// A rig whose right image lies `right_shift_px` right of where its calibration puts it (every
// measured disparity that much too small), driven forward 20 pairs. Returns the last pair's
// correction and the median error of its published disparities against the true ones (px).
// Asserts that no id published before the correction started is published after it.
std::pair<double, double> disparityErrorWithRightShift(double right_shift_px,
                                                       const TrackerOptions& options) {
  SlantedPlaneScene scene;
  StereoTracker tracker(options, scene.calibration());
  StereoFrame frame;
  std::string why;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, right_shift_px, 0, 1, 0);
  cv::Vec3d c;
  std::set<uint32_t> ids_uncorrected;
  int renewed = 0;
  for (int k = 0; k < 20; ++k) {
    c = positionAt(k);
    cv::Mat right;
    cv::warpAffine(scene.render(c, 0.5), right, shift, scene.size(), cv::INTER_LINEAR,
                   cv::BORDER_REFLECT);
    EXPECT_TRUE(tracker.process(scene.render(c, 0), right, 0.1 * k, nullptr, &frame, &why)) << why;
    renewed += frame.stats.ids_renewed;
    for (const TrackedFeature& f : frame.features) {
      if (frame.stats.disparity_offset_corrected_px == 0) {
        ids_uncorrected.insert(f.id);
      } else {
        EXPECT_EQ(ids_uncorrected.count(f.id), 0u) << "id " << f.id << " at pair " << k;
      }
    }
  }
  EXPECT_EQ(renewed > 100, frame.stats.disparity_offset_corrected_px != 0) << renewed;
  std::vector<double> errors;
  for (const TrackedFeature& f : frame.features) {
    const double depth = scene.pointAt(c, f.left.x, f.left.y)[2] - c[2];
    errors.push_back(scene.calibration().fx * 0.5 / depth - (f.left.x - f.right.x));
  }
  EXPECT_GE(errors.size(), 100u);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return {frame.stats.disparity_offset_corrected_px, errors[errors.size() / 2]};
}

// stereo/correct_disparity_offset: the rig check's offset, once beyond half a pixel, is taken out
// of the published right columns, and the tracks go on under new ids; a rig that agrees with its
// calibration is left as it is.
TEST(StereoTracker, ARigsDisparityOffsetIsTakenOutOfThePublishedFeatures) {
  TrackerOptions options;
  const auto [correction, error] = disparityErrorWithRightShift(1.0, options);
  std::printf("right image 1 px right: correction %.3f px, median disparity error %.3f px\n",
              correction, error);
  EXPECT_NEAR(correction, -1.0, 0.15);
  EXPECT_LT(std::abs(error), 0.15);
  const auto [no_correction, rig_error] = disparityErrorWithRightShift(0.0, options);
  EXPECT_EQ(no_correction, 0.0);
  EXPECT_LT(std::abs(rig_error), 0.1);
  options.correct_disparity_offset = false;
  const auto [off, off_error] = disparityErrorWithRightShift(1.0, options);
  EXPECT_EQ(off, 0.0);
  EXPECT_NEAR(off_error, 1.0, 0.15);
}

// The second pair has no motion to predict from (no twist, no last motion): the camera moved
// 0.6 m sideways (30 px of flow at the plane's 8 m, 23-37 px over its slant). Returns the
// features continued into it and the median error of their positions (px).
std::pair<int, double> continuedIntoAnUnpredictedPair(bool predict, bool* fitted_first) {
  SlantedPlaneScene scene;
  TrackerOptions options;
  options.predict_with_last_motion = predict;
  StereoTracker tracker(options, scene.calibration());
  const cv::Vec3d c0(0, 0, 0), c1(0.6, 0, 0);
  StereoFrame first, second;
  std::string why;
  EXPECT_TRUE(
      tracker.process(scene.render(c0, 0), scene.render(c0, 0.5), 0, nullptr, &first, &why));
  EXPECT_TRUE(
      tracker.process(scene.render(c1, 0), scene.render(c1, 0.5), 0.1, nullptr, &second, &why));
  *fitted_first = second.stats.predicted_from_first_matches;
  std::map<uint32_t, cv::Vec3d> first_point;
  for (const TrackedFeature& f : first.features)
    first_point[f.id] = scene.pointAt(c0, f.left.x, f.left.y);
  std::vector<double> errors;
  for (const TrackedFeature& f : second.features) {
    if (!first_point.count(f.id)) continue;
    const cv::Point2d truth = scene.project(c1, first_point[f.id]);
    errors.push_back(std::hypot(truth.x - f.left.x, truth.y - f.left.y));
  }
  if (errors.empty()) return {0, 1e9};
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return {static_cast<int>(errors.size()), errors[errors.size() / 2]};
}

TEST(StereoTracker, AnUnpredictedPairIsPredictedFromAFirstFit) {
  bool fitted_first = false;
  const auto [with, with_error] = continuedIntoAnUnpredictedPair(true, &fitted_first);
  EXPECT_TRUE(fitted_first);
  bool fitted_without = true;
  const auto [without, without_error] = continuedIntoAnUnpredictedPair(false, &fitted_without);
  EXPECT_FALSE(fitted_without);
  std::printf("continued: %d (median error %.3f px) with the first fit, %d (%.3f px) without\n",
              with, with_error, without, without_error);
  // Measured: 413 against 273; after half this step (0.3 m) 417 continue either way.
  EXPECT_GE(with, 380);
  EXPECT_LT(without, 330);
  EXPECT_LT(with_error, 0.25);
}

constexpr int kBackingFrames = 20;
constexpr double kBackingStep = 0.5;

// The camera backs away from the plane, 0.5 m per pair from 8 m: the image contracts to 0.46 in
// 20 pairs and the tracks come together, as when a robot reverses. Returns the smallest distance
// between two features of one frame and the tracks ended for crowding; *from_first: features of the
// first frame still tracked at the end.
double closestFeaturesBackingAway(int* crowded, int* from_first) {
  SlantedPlaneScene scene;
  StereoTracker tracker(TrackerOptions(), scene.calibration());
  double closest = 1e9;
  *crowded = 0;
  std::set<uint32_t> first_ids;
  StereoFrame frame;
  for (int k = 0; k < kBackingFrames; ++k) {
    const cv::Vec3d c(0.02 * k, 0, -kBackingStep * k);
    std::string why;
    EXPECT_TRUE(
        tracker.process(scene.render(c, 0), scene.render(c, 0.5), 0.1 * k, nullptr, &frame, &why));
    *crowded += frame.stats.crowded;
    for (size_t i = 0; i < frame.features.size(); ++i) {
      if (k == 0) first_ids.insert(frame.features[i].id);
      for (size_t j = 0; j < i; ++j) {
        closest = std::min(closest, cv::norm(frame.features[i].left - frame.features[j].left));
      }
    }
  }
  *from_first = 0;
  for (const TrackedFeature& f : frame.features) *from_first += first_ids.count(f.id);
  return closest;
}

TEST(StereoTracker, TracksComingTogetherKeepTheOldest) {
  int crowded = 0, from_first = 0;
  const double closest = closestFeaturesBackingAway(&crowded, &from_first);
  std::printf(
      "backing away: closest features %.2f px, %d tracks ended crowded, %d of the first "
      "frame's still tracked\n",
      closest, crowded, from_first);
  // Measured: 5.00 px, 57 ended, 388 of the first frame's tracks go on (424 without the check,
  // which gave 3.98 px). Tracks end at half of min_feature_distance (new corners keep all of it).
  EXPECT_GE(closest, 0.5 * TrackerOptions().min_feature_distance - 0.01);
  EXPECT_GT(crowded, 20);
  EXPECT_GT(from_first, 300);
}

}  // namespace
}  // namespace ekf_vislam
