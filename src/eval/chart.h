// The evaluation report's charts as data: the report writes them to charts.json, and
// scripts/plot_charts.py (matplotlib) draws each one as the PNG it names.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

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
};

/// One entry of charts.json: `file` (the PNG's name in the report folder), `kind` ("line" or
/// "bar") and the chart's fields under their names here; NaN is written as null (nlohmann-json's
/// rule for numbers JSON cannot hold).
nlohmann::ordered_json toJson(const LineChart& chart, const std::string& file);
nlohmann::ordered_json toJson(const BarChart& chart, const std::string& file);

}  // namespace spool_vision::chart
