#include "ekf_vislam/core/estimator_hints.h"

#include "ekf_vislam/core/health_monitor.h"
#include "ekf_vislam/core/vislam_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

namespace ekf_vislam {
namespace {

TEST(StateHints, AFreshEstimatorHasNothingToSay) {
  const VislamEstimator estimator{VislamOptions()};
  const StateHints hints = stateHints(estimator);
  for (const std::string* hint : hints.all()) EXPECT_EQ(*hint, "");
  // all() lists each hint once.
  const auto all = hints.all();
  const std::set<const std::string*> distinct(all.begin(), all.end());
  EXPECT_EQ(distinct.size(), StateHints::kCount);
}

TEST(StateHints, ATwistTravellingOffItsXAxisIsSaid) {
  // Dead reckoning on a twist that travels 3 degrees off its x axis (a camera's axes, not the
  // vehicle's) for 40 s at 10 Hz: the travel hint says so, as travelDirectionHint on the
  // estimator's reading does; no other hint speaks.
  VislamOptions options;
  options.mode = EstimatorMode::kDeadReckoning;
  VislamEstimator estimator(options);
  const double yaw = 3.0 * M_PI / 180.0;
  for (int k = 0; k <= 400; ++k) {
    TwistData twist;
    twist.stamp = 0.1 * k;
    twist.v_imu = 10.0 * Eigen::Vector3d(std::cos(yaw), std::sin(yaw), 0.0);
    estimator.feedTwist(twist);
  }
  const StateHints hints = stateHints(estimator);
  EXPECT_NE(hints.travel, "");
  EXPECT_EQ(hints.travel, travelDirectionHint(estimator.travelDirection(), options.vehicle));
  EXPECT_NE(hints.travel.find("3.00 deg towards its y"), std::string::npos) << hints.travel;
  for (const std::string* hint : hints.all()) {
    if (hint != &hints.travel) {
      EXPECT_EQ(*hint, "") << *hint;
    }
  }
}

}  // namespace
}  // namespace ekf_vislam
