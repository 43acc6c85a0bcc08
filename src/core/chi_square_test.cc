#include "ekf_vislam/core/chi_square.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ekf_vislam {
namespace {

TEST(ChiSquare, QuantilesMatchTables) {
  // Reference values (R: qchisq(p, k)).
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.841459, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.95, 2), 5.991465, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.95, 3), 7.814728, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.95, 4), 9.487729, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.95, 6), 12.591587, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.99, 3), 11.344867, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.5, 10), 9.341818, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.975, 60), 83.297675, 1e-4);
}

TEST(ChiSquare, GateUsesUpperQuantileNotLower) {
  // msckf_vio #124 used the 0.05 quantile (0.711 for 4 dof) and rejected nearly everything.
  EXPECT_NEAR(chiSquareQuantile(0.05, 4), 0.710723, 1e-5);
  EXPECT_GT(chiSquareQuantile(0.95, 4), 9.0);
}

TEST(ChiSquare, CdfInvertsQuantile) {
  for (int k : {1, 2, 3, 4, 7, 30}) {
    for (double p : {0.01, 0.3, 0.95, 0.999}) {
      EXPECT_NEAR(chiSquareCdf(chiSquareQuantile(p, k), k), p, 1e-9);
    }
  }
}

TEST(ChiSquare, InvalidArgumentsGiveNaN) {
  EXPECT_TRUE(std::isnan(chiSquareQuantile(1.0, 3)));
  EXPECT_TRUE(std::isnan(chiSquareQuantile(0.5, 0)));
}

}  // namespace
}  // namespace ekf_vislam
