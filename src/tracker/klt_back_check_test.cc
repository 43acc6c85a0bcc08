#include "ekf_vislam/tracker/klt_back_check.h"

#include "testing/blurred_texture.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <cmath>

namespace ekf_vislam {
namespace {

// A blurred random texture and the same texture moved by (3.0, -2.0) px.
struct ShiftedPair {
  ShiftedPair() {
    first = testing::blurredTexture(cv::Size(320, 240), 3, 1.5);
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 3.0, 0, 1, -2.0);
    cv::warpAffine(first, second, shift, first.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    cv::buildOpticalFlowPyramid(first, first_pyramid, klt.window, klt.levels, true);
    cv::buildOpticalFlowPyramid(second, second_pyramid, klt.window, klt.levels, true);
  }
  KltSettings klt{cv::Size(21, 21), 2,
                  cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01)};
  cv::Mat first, second;
  std::vector<cv::Mat> first_pyramid, second_pyramid;
};

TEST(KltBackCheck, KeepsTrueMatchesRefusesAWrongOneAndSkipsNonCandidates) {
  const ShiftedPair pair;
  const std::vector<cv::Point2f> origin = {{80, 60}, {160, 120}, {240, 180}, {100, 170}};
  std::vector<cv::Point2f> moved;
  for (const cv::Point2f& p : origin) moved.emplace_back(p.x + 3.0f, p.y - 2.0f);
  moved[2] += cv::Point2f(9.0f, 7.0f);  // a wrong match: its back-tracking lands elsewhere
  const std::vector<uint8_t> passed =
      backCheck(pair.second_pyramid, pair.first_pyramid, moved, origin, {0, 2, 3}, pair.klt, 0.5);
  ASSERT_EQ(passed.size(), origin.size());
  EXPECT_EQ(passed[0], 1);
  EXPECT_EQ(passed[1], 0);  // not a candidate: never tracked back
  EXPECT_EQ(passed[2], 0);
  EXPECT_EQ(passed[3], 1);
  EXPECT_TRUE(backCheck(pair.second_pyramid, pair.first_pyramid, moved, origin, {}, pair.klt,
                        0.5) == std::vector<uint8_t>(origin.size(), 0));
}

TEST(KltBackCheck, ACandidateGetsWhatABackTrackingOfEveryPointGives) {
  const ShiftedPair pair;
  std::vector<cv::Point2f> origin, moved;
  cv::RNG rng(5);
  for (int i = 0; i < 40; ++i) {
    origin.emplace_back(rng.uniform(30.f, 290.f), rng.uniform(30.f, 210.f));
    // Every third match is off by up to 1.5 px: those fail the check.
    const float off = i % 3 == 0 ? 1.5f : 0.f;
    moved.emplace_back(origin.back().x + 3.0f + rng.uniform(-off, off),
                       origin.back().y - 2.0f + rng.uniform(-off, off));
  }
  std::vector<cv::Point2f> back = origin;
  std::vector<uint8_t> status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(pair.second_pyramid, pair.first_pyramid, moved, back, status, error,
                           pair.klt.window, pair.klt.levels, pair.klt.criteria,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<size_t> odd;
  for (size_t i = 1; i < origin.size(); i += 2) odd.push_back(i);
  const std::vector<uint8_t> passed =
      backCheck(pair.second_pyramid, pair.first_pyramid, moved, origin, odd, pair.klt, 0.3);
  int kept = 0;
  for (size_t i = 0; i < origin.size(); ++i) {
    const bool all_points = status[i] && cv::norm(back[i] - origin[i]) <= 0.3;
    EXPECT_EQ(passed[i], i % 2 == 1 && all_points) << i;
    kept += passed[i];
  }
  EXPECT_GE(kept, 12);  // 13 odd points are exact matches
  EXPECT_LE(kept, 15);
}

TEST(KltBackCheck, SettingsKeepAtMostTheForwardLevels) {
  const KltSettings forward{cv::Size(15, 15), 3, cv::TermCriteria()};
  EXPECT_EQ(backCheckSettings(forward, 0).levels, 0);
  EXPECT_EQ(backCheckSettings(forward, 2).levels, 2);
  EXPECT_EQ(backCheckSettings(forward, 5).levels, 3);
  EXPECT_EQ(backCheckSettings(forward, 0).window, forward.window);
}

// The backward KLT starts where a consistent match returns to: on the full image alone it keeps
// the true matches and refuses the wrong ones, near (1.5 px) and far (up to 25 px, beyond the
// window's reach), as the pyramidal one does.
TEST(KltBackCheck, OnTheFullImageAloneDecidesAsThePyramid) {
  const ShiftedPair pair;
  const std::vector<float> offsets = {0.f, 1.5f, 3.f, 9.f, 25.f};
  std::vector<cv::Point2f> origin, moved;
  std::vector<size_t> all;
  cv::RNG rng(7);
  for (int i = 0; i < 60; ++i) {
    origin.emplace_back(rng.uniform(40.f, 280.f), rng.uniform(40.f, 200.f));
    const float off = offsets[i % offsets.size()];
    const float angle = rng.uniform(0.f, 6.2832f);
    moved.emplace_back(origin.back().x + 3.0f + off * std::cos(angle),
                       origin.back().y - 2.0f + off * std::sin(angle));
    all.push_back(all.size());
  }
  const std::vector<uint8_t> full_image =
      backCheck(pair.second_pyramid, pair.first_pyramid, moved, origin, all,
                backCheckSettings(pair.klt, 0), 0.5);
  const std::vector<uint8_t> pyramid =
      backCheck(pair.second_pyramid, pair.first_pyramid, moved, origin, all, pair.klt, 0.5);
  for (size_t i = 0; i < origin.size(); ++i) {
    const bool true_match = i % offsets.size() == 0;
    EXPECT_EQ(full_image[i], true_match ? 1 : 0) << i;
    EXPECT_EQ(pyramid[i], true_match ? 1 : 0) << i;
  }
}

}  // namespace
}  // namespace ekf_vislam
