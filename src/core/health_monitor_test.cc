#include "ekf_vislam/core/health_monitor.h"

#include <gtest/gtest.h>

#include <string>

namespace ekf_vislam {
namespace {

TEST(DisagreementHint, OrdinaryGatingSaysNothing) {
  // The KITTI course files gate 1-3 % of the re-observed landmarks, a fault bag with 5 % gross
  // outliers about 7 %.
  EXPECT_EQ(disagreementHint(1624, 53613), "");
  EXPECT_EQ(disagreementHint(20, 80), "");  // exactly the fraction: not beyond it
  EXPECT_EQ(disagreementHint(0, 0), "");
}

TEST(DisagreementHint, TooFewObservationsSayNothing) {
  EXPECT_EQ(disagreementHint(40, 9), "");  // 49 observations, 82 % gated
}

TEST(DisagreementHint, ManyGatedNameTheFractionAndTheLikelyCauses) {
  // The KITTI-360 course file with its twist in other axes than its extrinsic: 53 % gated.
  const std::string hint = disagreementHint(18037, 16083);
  EXPECT_NE(hint.find("52.9 %"), std::string::npos) << hint;
  EXPECT_NE(hint.find("18037 of 34120"), std::string::npos) << hint;
  EXPECT_NE(hint.find("axes"), std::string::npos) << hint;
  EXPECT_NE(hint.find("time stamps"), std::string::npos) << hint;
  EXPECT_NE(disagreementHint(11, 39), "");  // 22 % of 50
}

TEST(HealthMonitor, MostObservationsGatedForManyFramesIsDivergence) {
  VislamOptions options;
  options.health.max_rejected_frames = 3;
  HealthMonitor monitor(options);
  std::string why;
  EXPECT_FALSE(monitor.diverged(20, 19, 1.0, &why));
  EXPECT_FALSE(monitor.diverged(20, 19, 1.0, &why));
  EXPECT_FALSE(monitor.diverged(20, 2, 1.0, &why));  // a good frame restarts the count
  EXPECT_FALSE(monitor.diverged(20, 19, 1.0, &why));
  EXPECT_FALSE(monitor.diverged(20, 19, 1.0, &why));
  EXPECT_TRUE(monitor.diverged(20, 19, 1.0, &why));
  EXPECT_NE(why.find("3 consecutive frames"), std::string::npos) << why;
  EXPECT_FALSE(monitor.diverged(5, 5, 1.0, &why));  // fewer than 10 candidates: not counted
  EXPECT_TRUE(monitor.diverged(20, 0, options.health.max_position_sigma * 2.0, &why));
  EXPECT_NE(why.find("blew up"), std::string::npos) << why;
}

}  // namespace
}  // namespace ekf_vislam
