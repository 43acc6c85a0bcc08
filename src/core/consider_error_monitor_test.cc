#include "ekf_vislam/core/consider_error_monitor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace ekf_vislam {
namespace {

TEST(ConsiderErrorMonitor, PoolsTheUpdatesEvidenceIntoOneLeastSquaresEstimate) {
  ConsiderErrorMonitor monitor;
  EXPECT_EQ(monitor.error(), 0.0);
  EXPECT_TRUE(std::isinf(monitor.whiteSigma()));
  // Two updates reading -0.02 (information 100) and -0.05 (information 300).
  monitor.add({-0.02 * 100.0, 100.0});
  monitor.add({-0.05 * 300.0, 300.0});
  EXPECT_NEAR(monitor.error(), -0.0425, 1e-15);
  EXPECT_NEAR(monitor.whiteSigma(), 0.05, 1e-15);
  EXPECT_EQ(monitor.updates(), 2u);
}

TEST(ConsiderErrorMonitor, IgnoresUpdatesWithoutEvidenceOrWithNonFiniteNumbers) {
  ConsiderErrorMonitor monitor;
  monitor.add({1.0, 0.0});
  monitor.add({std::numeric_limits<double>::quiet_NaN(), 10.0});
  monitor.add({1.0, std::numeric_limits<double>::infinity()});
  monitor.add({1.0, -5.0});
  EXPECT_EQ(monitor.updates(), 0u);
  EXPECT_EQ(monitor.error(), 0.0);
  monitor.add({0.3, 10.0});
  monitor.clear();
  EXPECT_EQ(monitor.updates(), 0u);
}

}  // namespace
}  // namespace ekf_vislam
