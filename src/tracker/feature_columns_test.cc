#include "ekf_vislam/tracker/feature_columns.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

namespace ekf_vislam {
namespace {

/// Frames holding ids over the frame ranges given ([first, last] each).
std::vector<StereoFrame> framesOf(const std::map<uint32_t, std::pair<size_t, size_t>>& spans,
                                  size_t num_frames) {
  std::vector<StereoFrame> frames(num_frames);
  for (const auto& [id, span] : spans) {
    for (size_t k = span.first; k <= span.second; ++k) {
      TrackedFeature f;
      f.id = id;
      frames[k].features.push_back(f);
    }
  }
  return frames;
}

TEST(FeatureColumns, OneColumnPerIdInIdOrderWithoutReuse) {
  const auto frames = framesOf({{7, {0, 2}}, {3, {1, 4}}, {12, {5, 6}}}, 7);
  const FeatureColumns columns = assignFeatureColumns(frames, 0);
  EXPECT_EQ(columns.columns, 3u);
  EXPECT_EQ(columns.column_of_id.at(3), 0u);
  EXPECT_EQ(columns.column_of_id.at(7), 1u);
  EXPECT_EQ(columns.column_of_id.at(12), 2u);
}

TEST(FeatureColumns, AColumnIsTakenAgainOnlyAfterTheGap) {
  // Id 1 ends at frame 2; with a gap of 3 its column is free from frame 6 on: id 2 (from 5) takes
  // a new one, id 3 (from 6) takes id 1's.
  const auto frames = framesOf({{1, {0, 2}}, {2, {5, 9}}, {3, {6, 8}}}, 10);
  const FeatureColumns columns = assignFeatureColumns(frames, 3);
  EXPECT_EQ(columns.columns, 2u);
  EXPECT_EQ(columns.column_of_id.at(1), 0u);
  EXPECT_EQ(columns.column_of_id.at(2), 1u);
  EXPECT_EQ(columns.column_of_id.at(3), 0u);
}

TEST(FeatureColumns, SharedColumnsNeverOverlapAndKeepTheirGaps) {
  // A long sequence's churn: 60 new ids a frame, each living 1-20 frames.
  std::mt19937 rng(4);
  std::uniform_int_distribution<size_t> life(1, 20);
  std::map<uint32_t, std::pair<size_t, size_t>> spans;
  const size_t num_frames = 300;
  uint32_t id = 0;
  for (size_t k = 0; k < num_frames; ++k) {
    for (int n = 0; n < 60; ++n) spans[id++] = {k, std::min(num_frames - 1, k + life(rng) - 1)};
  }
  const auto frames = framesOf(spans, num_frames);
  const FeatureColumns columns = assignFeatureColumns(frames, kColumnReuseGap);
  EXPECT_EQ(assignFeatureColumns(frames, 0).columns, spans.size());
  // At most the ids alive, or waiting out their gap, at once: 60 x (20 + 10).
  EXPECT_LE(columns.columns, 60u * (20 + kColumnReuseGap));
  EXPECT_LT(columns.columns, spans.size() / 8);
  std::map<size_t, std::vector<std::pair<size_t, size_t>>> by_column;
  for (const auto& [i, span] : spans) by_column[columns.column_of_id.at(i)].push_back(span);
  for (auto& [column, runs] : by_column) {
    std::sort(runs.begin(), runs.end());
    for (size_t r = 1; r < runs.size(); ++r) {
      EXPECT_GE(runs[r].first, runs[r - 1].second + 1 + kColumnReuseGap) << "column " << column;
    }
  }
}

TEST(FeatureColumns, ColumnsAreSharedByDefaultOnlyBeyondAGibibyte) {
  // The 51-frame KITTI clips (about 3000 ids): a column per id, as the course files.
  EXPECT_EQ(defaultReuseGap(3000, 51), 0u);
  // A KITTI sequence of 1100 frames at 60 new ids a frame (2.1 GiB with a column per id).
  EXPECT_EQ(defaultReuseGap(66000, 1100), kColumnReuseGap);
  EXPECT_NEAR(freshColumnsBytes(66000, 1100) / (1 << 30), 2.16, 0.01);
}

}  // namespace
}  // namespace ekf_vislam
