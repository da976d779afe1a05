// Small PNG charts drawn with OpenCV (axes, ticks, grid, legend) for the evaluation report.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace spool_vision::chart
{
/// A horizontal reference line, e.g. a bar or a tolerance.
struct Level
{
  std::string label;
  double y = 0.0;
};

/// Points of one series; NaN y values are gaps.
struct Series
{
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  bool line = true;  ///< false: markers only
};

struct LineChart
{
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<Series> series;
  std::vector<Level> levels;
};

/// One bar per category and group; NaN values draw no bar.
struct BarGroup
{
  std::string label;
  std::vector<double> values;
};

struct BarChart
{
  std::string title;
  std::string y_label;
  std::vector<std::string> categories;
  std::vector<BarGroup> groups;
  double y_max = std::numeric_limits<double>::quiet_NaN();  ///< NaN = from the data
  std::vector<Level> levels;
};

cv::Mat draw(const LineChart& chart);
cv::Mat draw(const BarChart& chart);

/// "Nice" tick positions (1, 2, 2.5 or 5 times a power of ten) covering [lo, hi].
std::vector<double> ticks(double lo, double hi, int approx_count);

}  // namespace spool_vision::chart
