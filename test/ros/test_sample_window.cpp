// SampleWindow: the order statistics the "Processing" diagnostics report.
#include <gtest/gtest.h>

#include <cmath>

#include "../../src/ros/sample_window.h"

using spool_vision::SampleWindow;

TEST(SampleWindow, NearestRankQuantiles)
{
  SampleWindow window;
  for (const double v : {7.0, 1.0, 10.0, 3.0, 5.0, 2.0, 9.0, 4.0, 8.0, 6.0})
    window.add(v);
  EXPECT_EQ(window.size(), 10u);
  EXPECT_DOUBLE_EQ(window.quantile(0.0), 1.0);
  EXPECT_DOUBLE_EQ(window.quantile(0.5), 5.0);    // the 5th of 10
  EXPECT_DOUBLE_EQ(window.quantile(0.95), 10.0);  // ceil(9.5) = 10th
  EXPECT_DOUBLE_EQ(window.quantile(0.9), 9.0);
  EXPECT_DOUBLE_EQ(window.quantile(1.0), 10.0);
  // Asking again after the reordering gives the same answers.
  EXPECT_DOUBLE_EQ(window.quantile(0.5), 5.0);
}

TEST(SampleWindow, OneSlowFrameShowsInTheMaxAndNotTheMedian)
{
  SampleWindow window;
  for (int i = 0; i < 99; ++i)
    window.add(2.0);
  window.add(40.0);
  EXPECT_DOUBLE_EQ(window.quantile(0.5), 2.0);
  EXPECT_DOUBLE_EQ(window.quantile(0.95), 2.0);
  EXPECT_DOUBLE_EQ(window.quantile(1.0), 40.0);
}

TEST(SampleWindow, EmptyIsNaNAndClearEmpties)
{
  SampleWindow window;
  EXPECT_TRUE(std::isnan(window.quantile(0.5)));
  window.add(3.0);
  EXPECT_FALSE(window.empty());
  window.clear();
  EXPECT_TRUE(window.empty());
  EXPECT_TRUE(std::isnan(window.quantile(1.0)));
}
