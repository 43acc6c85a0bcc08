#include "ekf_vislam/core/median.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TEST(UpperMedian, TheMiddleElementOrTheUpperOfTheTwo) {
  std::vector<double> odd = {5.0, -1.0, 3.0, 9.0, 0.5};
  EXPECT_EQ(upperMedian(&odd), 3.0);
  std::vector<float> even = {4.f, 1.f, 3.f, 2.f};
  EXPECT_EQ(upperMedian(&even), 3.f);
  std::vector<double> one = {7.0};
  EXPECT_EQ(upperMedian(&one), 7.0);
}

TEST(Median, TheMiddleElementOrTheMeanOfTheTwo) {
  std::vector<double> odd = {5.0, -1.0, 3.0, 9.0, 0.5};
  EXPECT_EQ(median(&odd), 3.0);
  std::vector<double> even = {4.0, 1.0, 3.5, 2.0};
  EXPECT_EQ(median(&even), 2.75);
  std::vector<double> two = {7.0, -7.0};
  EXPECT_EQ(median(&two), 0.0);
}

}  // namespace
}  // namespace ekf_vislam
