#include "chart.h"

namespace spool_vision::chart
{
using Json = nlohmann::ordered_json;

Json toJson(const LineChart& chart, const std::string& file)
{
  Json series = Json::array();
  for (const Series& s : chart.series)
    series.push_back({{"label", s.label}, {"x", s.x}, {"y", s.y}, {"line", s.line}});
  Json levels = Json::array();
  for (const Level& l : chart.levels)
    levels.push_back({{"label", l.label}, {"y", l.y}});
  return {{"file", file},
          {"kind", "line"},
          {"title", chart.title},
          {"x_label", chart.x_label},
          {"y_label", chart.y_label},
          {"series", series},
          {"levels", levels}};
}

Json toJson(const BarChart& chart, const std::string& file)
{
  Json groups = Json::array();
  for (const BarGroup& g : chart.groups)
    groups.push_back({{"label", g.label}, {"values", g.values}});
  return {{"file", file},         {"kind", "bar"},
          {"title", chart.title}, {"y_label", chart.y_label},
          {"y_max", chart.y_max}, {"categories", chart.categories},
          {"groups", groups}};
}

}  // namespace spool_vision::chart
