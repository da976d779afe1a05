// The report: the §7 headline table, the failure breakdown, the thesis analyses as Markdown
// tables, and the data of their charts (charts.json, drawn by scripts/plot_charts.py).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "chart.h"
#include "spool_vision/eval/evaluation.h"

namespace spool_vision
{
namespace
{
constexpr double kToDeg = 180.0 / M_PI;

std::string fixed(double v, int decimals)
{
  if (!std::isfinite(v))
    return "n/a";
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string percent(double fraction, int decimals = 1)
{
  return std::isfinite(fraction) ? fixed(100.0 * fraction, decimals) + "%" : "n/a";
}

std::string rateText(const Rate& r)
{
  if (r.frames == 0)
    return "n/a (no frames)";
  return percent(r.value()) + " (" + std::to_string(r.hits) + "/" + std::to_string(r.frames) + ")";
}

std::string markdownTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows)
{
  std::ostringstream out;
  auto line = [&out](const std::vector<std::string>& cells)
  {
    out << "|";
    for (const std::string& c : cells)
      out << " " << c << " |";
    out << "\n";
  };
  line(header);
  out << "|";
  for (size_t i = 0; i < header.size(); ++i)
    out << " --- |";
  out << "\n";
  for (const auto& row : rows)
    line(row);
  return out.str();
}

BarRow::Cell rateCell(const Rate& r, double limit, bool at_least)
{
  BarRow::Cell c;
  c.measured = rateText(r);
  c.applies = std::isfinite(limit);
  c.limit = c.applies ? (at_least ? "≥ " : "≤ ") + percent(limit, 0) : "-";
  c.pass = r.frames > 0 && (at_least ? r.value() >= limit : r.value() <= limit);
  return c;
}

BarRow::Cell valueCell(double value, double limit, const std::function<std::string(double)>& show)
{
  BarRow::Cell c;
  c.measured = show(value);
  c.applies = std::isfinite(limit);
  c.limit = c.applies ? "≤ " + show(limit) : "-";
  c.pass = std::isfinite(value) && value <= limit;
  return c;
}

// A count bar: at most `max` hits, shown as "hits of frames".
BarRow::Cell countCell(const Rate& r, double max)
{
  BarRow::Cell c;
  c.applies = std::isfinite(max);
  c.limit = c.applies ? "≤ " + fixed(max, 0) : "-";
  c.measured = std::to_string(r.hits) + " of " + std::to_string(r.frames);
  c.pass = r.hits <= max;
  return c;
}

// A spread's statistic: where it has no value, whether there were no frames or the detector left
// the quantity unmeasured (NaN).
BarRow::Cell spreadCell(const Spread& spread, double value, double limit,
                        const std::function<std::string(double)>& show)
{
  BarRow::Cell c = valueCell(value, limit, show);
  if (spread.count == 0)
    c.measured = spread.values > 0 ? "n/a (not measured)" : "n/a (no frames)";
  else
    c.measured += " (n = " + std::to_string(spread.count) + ")";
  return c;
}

std::string verdict(const BarRow::Cell& c)
{
  return !c.applies ? "info" : (c.pass ? "pass" : "**FAIL**");
}

// The setups that ran the thesis analyses (variants, lamps, poses).
std::vector<size_t> analysedSetups(const EvaluationResult& result)
{
  std::vector<size_t> out;
  for (size_t s = 0; s < result.config.setups.size(); ++s)
    if (result.config.setups[s].analyses)
      out.push_back(s);
  return out;
}

std::string toleranceText(const HoleTolerance& t)
{
  auto part = [](double px, double fraction)
  { return fraction > 0.0 ? "max(" + fixed(px, 1) + " px, " + percent(fraction, 0) + " r)" : fixed(px, 1) + " px"; };
  return "centre " + part(t.centre_px, t.centre_fraction) + ", radius " + part(t.radius_px, t.radius_fraction);
}

// The series called `label`, appended when new.
chart::Series& seriesFor(chart::LineChart& c, const std::string& label, bool line)
{
  for (chart::Series& s : c.series)
    if (s.label == label)
      return s;
  c.series.push_back({label, {}, {}, line});
  return c.series.back();
}

void write(const std::string& text, const std::filesystem::path& path)
{
  std::ofstream out(path);
  out << text;
  if (!out)
    throw std::runtime_error("cannot write " + path.string());
}

// --- the sections ------------------------------------------------------------------------------

std::string breakdown(const EvaluationResult& result)
{
  std::vector<std::vector<std::string>> rows;
  for (size_t s = 0; s < result.setups.size(); ++s)
    for (size_t g = 0; g < result.setups[s].per_group.size(); ++g)
    {
      const GroupResult& r = result.setups[s].per_group[g];
      const Metrics& m = r.metrics;
      rows.push_back({result.config.setups[s].name, result.config.groups[g].name, std::to_string(r.frames),
                      std::to_string(m.flange_found.frames), std::to_string(m.missed), std::to_string(m.on_other_spool),
                      std::to_string(m.bogus), std::to_string(m.hole_found.frames),
                      std::to_string(m.hole_found_dark.frames), rateText(m.false_hole),
                      fixed(m.hole_centre_error_px.median, 2) + " / " + fixed(m.hole_centre_error_px.p95, 2),
                      fixed(m.hole_radius_error_px.median, 2) + " / " + fixed(m.hole_radius_error_px.p95, 2),
                      std::to_string(m.false_spool.frames), std::to_string(m.wrong_target.frames),
                      std::to_string(m.distance_error.count), fixed(m.time_ms.p95, 2) + " ms"});
    }
  return markdownTable(
      {"setup", "sets", "frames", "flange-eligible", "missed", "flange on another spool", "flange on no spool",
       "hole-eligible, lit", "hole-eligible, dark", "false holes", "hole centre error px (median / p95)",
       "hole radius error px (median / p95)", "frames without a spool centre", "frames with neighbours",
       "correct flanges measured", "time p95"},
      rows);
}

std::string variantTable(const EvaluationResult& result, const VariantAnalysis& analysis)
{
  std::vector<std::vector<std::string>> rows;
  for (size_t s : analysedSetups(result))
    for (const VariantResult& row : analysis.rows)
    {
      const Metrics& m = row.per_setup[s];
      rows.push_back({result.config.setups[s].name, row.label, rateText(m.flange_found), rateText(m.hole_found),
                      rateText(m.false_hole), rateText(m.wrong_target), rateText(m.false_spool),
                      fixed(m.time_ms.median, 2)});
    }
  return markdownTable(
      {"setup", "variant", "flange found", "hole found", "false holes", "wrong target", "false spool", "median ms"},
      rows);
}

chart::BarChart variantChart(const EvaluationResult& result, const VariantAnalysis& analysis)
{
  chart::BarChart c;
  c.title = analysis.title;
  c.y_label = "% of frames";
  c.y_max = 100.0;
  for (const VariantResult& row : analysis.rows)
    c.categories.push_back(row.label);
  const std::vector<std::pair<std::string, std::function<const Rate&(const Metrics&)>>> metrics = {
      {"flange found", [](const Metrics& m) -> const Rate& { return m.flange_found; }},
      {"hole found", [](const Metrics& m) -> const Rate& { return m.hole_found; }},
      {"false holes", [](const Metrics& m) -> const Rate& { return m.false_hole; }}};
  for (size_t s : analysedSetups(result))
    for (const auto& [name, rate] : metrics)
    {
      chart::BarGroup group{name + ", " + result.config.setups[s].name, {}};
      for (const VariantResult& row : analysis.rows)
        group.values.push_back(100.0 * rate(row.per_setup[s]).value());
      c.groups.push_back(group);
    }
  return c;
}

std::string distanceSection(const EvaluationResult& result, nlohmann::ordered_json& charts)
{
  std::vector<std::string> header = {"true distance (cm)"};
  chart::LineChart c{"Distance error straight on (thesis Fig. 4.16)",
                     "true distance (cm)",
                     "(measured - true) / true (%)",
                     {},
                     {{"+1%", 1.0}, {"-1%", -1.0}}};
  const std::vector<size_t> setups = analysedSetups(result);
  for (size_t s : setups)
  {
    header.insert(header.end(), {result.config.setups[s].name + ": measured (cm)", "error", "found"});
    c.series.push_back({result.config.setups[s].name, {}, {}, true});
  }
  std::vector<std::vector<std::string>> rows;
  for (const PosePoint& p : result.distance_sweep)
  {
    std::vector<std::string> row = {fixed(100.0 * p.distance, 1)};
    for (size_t k = 0; k < setups.size(); ++k)
    {
      const PoseMeasurement& m = p.per_setup[setups[k]];
      const double error = (m.distance - p.distance) / p.distance;
      row.insert(row.end(), {fixed(100.0 * m.distance, 2), percent(error, 2),
                             std::to_string(m.correct) + "/" + std::to_string(m.frames)});
      c.series[k].x.push_back(100.0 * p.distance);
      c.series[k].y.push_back(100.0 * error);
    }
    rows.push_back(row);
  }
  charts.push_back(chart::toJson(c, "distance.png"));
  return markdownTable(header, rows) + "\n![distance error](distance.png)\n";
}

std::string yawSection(const EvaluationResult& result, nlohmann::ordered_json& charts)
{
  std::vector<std::string> header = {"distance (cm)", "true yaw (°)"};
  chart::LineChart c{"Yaw error, -20 to 20 deg (thesis Table 4.1)", "true yaw (deg)", "measured - true (deg)", {}, {}};
  const std::vector<size_t> setups = analysedSetups(result);
  for (size_t s : setups)
    header.insert(header.end(), {result.config.setups[s].name + ": measured (°)", "error (°)", "error (%)"});
  std::vector<std::vector<std::string>> rows;
  for (const PosePoint& p : result.yaw_sweep)
  {
    std::vector<std::string> row = {fixed(100.0 * p.distance, 0), fixed(p.yaw * kToDeg, 2)};
    for (size_t s : setups)
    {
      const double error = (p.per_setup[s].yaw - p.yaw) * kToDeg;
      // The thesis' percentage error is relative to the true angle, undefined at 0 deg.
      const bool relative = std::abs(p.yaw) > 1e-3;
      row.insert(row.end(), {fixed(p.per_setup[s].yaw * kToDeg, 2), fixed(error, 3),
                             relative ? fixed(100.0 * std::abs(error / (p.yaw * kToDeg)), 2) : "-"});
      chart::Series& series =
          seriesFor(c, result.config.setups[s].name + ", " + fixed(100.0 * p.range, 0) + " cm", true);
      series.x.push_back(p.yaw * kToDeg);
      series.y.push_back(error);
    }
    rows.push_back(row);
  }
  charts.push_back(chart::toJson(c, "yaw.png"));
  return markdownTable(header, rows) + "\n![yaw error](yaw.png)\n";
}

std::string txSection(const EvaluationResult& result, nlohmann::ordered_json& charts, double tolerance)
{
  std::vector<std::string> header = {"distance (cm)", "true yaw (°)", "true tx_r (cm)"};
  chart::LineChart c{"Lateral error tx_r = D |tan yaw| near 0 deg (thesis Fig. 4.17)",
                     "true yaw (deg)",
                     "tx_r (cm)",
                     {},
                     {{"t_f = " + fixed(100.0 * tolerance, 2) + " cm", 100.0 * tolerance}}};
  const std::vector<size_t> setups = analysedSetups(result);
  for (size_t s : setups)
    header.insert(header.end(), {result.config.setups[s].name + ": tx_r (cm)", "within t_f"});
  std::vector<std::vector<std::string>> rows;
  for (const PosePoint& p : result.tx_sweep)
  {
    const std::string at = fixed(100.0 * p.range, 0) + " cm";
    const double truth = p.distance * std::abs(std::tan(p.yaw));
    std::vector<std::string> row = {fixed(100.0 * p.distance, 0), fixed(p.yaw * kToDeg, 2), fixed(100.0 * truth, 3)};
    chart::Series& true_series = seriesFor(c, "true, " + at, true);
    true_series.x.push_back(p.yaw * kToDeg);
    true_series.y.push_back(100.0 * truth);
    for (size_t s : setups)
    {
      const double measured = p.per_setup[s].lateral_offset;
      row.insert(row.end(), {fixed(100.0 * measured, 3),
                             std::isfinite(measured) ? (measured <= tolerance ? "yes" : "no") : "n/a"});
      chart::Series& series = seriesFor(c, result.config.setups[s].name + ", " + at, false);
      series.x.push_back(p.yaw * kToDeg);
      series.y.push_back(100.0 * measured);
    }
    rows.push_back(row);
  }
  charts.push_back(chart::toJson(c, "tx_r.png"));
  return markdownTable(header, rows) + "\n![tx_r](tx_r.png)\n";
}
}  // namespace

std::vector<BarRow> headlineRows(const EvaluationResult& result, size_t group)
{
  std::vector<BarRow> rows;
  auto add =
      [&](const std::string& bar, const std::function<BarRow::Cell(const QualityBars&, const GroupResult&)>& cell)
  {
    BarRow row{bar, {}};
    for (size_t s = 0; s < result.setups.size(); ++s)
      row.per_setup.push_back(cell(result.config.setups[s].bars, result.setups[s].per_group.at(group)));
    rows.push_back(row);
  };
  auto relative = [](double v) { return percent(v, 2); };
  auto degrees = [](double v) { return fixed(v, 3) + "°"; };
  auto ms = [](double v) { return fixed(v, 2) + " ms"; };
  add("flange found (target: half its rim in view, 50-110 cm, ±20°, ≤ 40° off its axis, all lamps)",
      [](const QualityBars& b, const GroupResult& r)
      { return rateCell(r.metrics.flange_found, b.flange_found_min, true); });
  add("hole found (front rim), bore shows through", [](const QualityBars& b, const GroupResult& r)
      { return rateCell(r.metrics.hole_found, b.hole_found_min, true); });
  add("hole found (front rim), bore in view but dark", [](const QualityBars& b, const GroupResult& r)
      { return rateCell(r.metrics.hole_found_dark, b.hole_dark_found_min, true); });
  add("false spool (no spool centre in view)", [](const QualityBars& b, const GroupResult& r)
      { return rateCell(r.metrics.false_spool, b.false_spool_max, false); });
  add("wrong target (neighbours in view)", [](const QualityBars& b, const GroupResult& r)
      { return rateCell(r.metrics.wrong_target, b.wrong_target_max, false); });
  add("depth more than " + percent(kAbsurdDepthError, 0) + " off the spool under the flange (detections)",
      [](const QualityBars& b, const GroupResult& r)
      { return countCell(r.metrics.depth_over_10_percent, b.depth_over_10_max); });
  add("of those: a ring inside the rim / an outline around it / the rim's height / no spool under it",
      [](const QualityBars&, const GroupResult& r)
      {
        const Metrics& m = r.metrics;
        BarRow::Cell c;
        c.limit = "-";
        c.measured = std::to_string(m.deep_inside) + " / " + std::to_string(m.deep_outside) + " / " +
                     std::to_string(m.deep_same_height) + " / " + std::to_string(m.deep_on_nothing);
        return c;
      });
  add("distance (depth) error, median", [&](const QualityBars& b, const GroupResult& r)
      { return valueCell(r.metrics.distance_error.median, b.distance_median_max, relative); });
  add("distance (depth) error, 95th percentile", [&](const QualityBars& b, const GroupResult& r)
      { return valueCell(r.metrics.distance_error.p95, b.distance_p95_max, relative); });
  add("yaw error, median", [&](const QualityBars& b, const GroupResult& r)
      { return valueCell(r.metrics.yaw_error_deg.median, b.yaw_median_max_deg, degrees); });
  add("yaw error, 95th percentile", [&](const QualityBars& b, const GroupResult& r)
      { return valueCell(r.metrics.yaw_error_deg.p95, b.yaw_p95_max_deg, degrees); });
  add("detector time per frame, median (one thread)", [&](const QualityBars& b, const GroupResult& r)
      { return valueCell(r.metrics.time_ms.median, b.time_median_max_ms, ms); });
  add("slowest frame / median (least of 3 runs)",
      [](const QualityBars& b, const GroupResult& r)
      {
        BarRow::Cell c = valueCell(r.worstRatio(), b.worst_ratio_max, [](double v) { return fixed(v, 1) + "x"; });
        c.measured += " (" + fixed(r.worst.ms, 2) + " ms, " + (r.worst_frame.empty() ? "-" : r.worst_frame) + ")";
        return c;
      });
  add("faster than cv::HoughCircles (same two-range job, same frames)",
      [](const QualityBars& b, const GroupResult& r)
      {
        BarRow::Cell c;
        c.applies = b.faster_than_baseline;
        c.limit = c.applies ? "ratio > 1" : "-";
        c.measured = fixed(r.speedRatio(), 2) + "x (" + fixed(r.baseline_ms, 2) + " ms vs " +
                     fixed(r.metrics.time_ms.median, 2) + " ms)";
        c.pass = r.speedRatio() > 1.0;
        return c;
      });
  return rows;
}

std::vector<BarRow> poseRows(const EvaluationResult& result, size_t group)
{
  std::vector<BarRow> rows;
  const bool bars = result.config.groups.at(group).pose_bars;
  // A bar's limit where this group takes issue 10's bars, else reported only.
  auto limit = [bars](double value) { return bars ? value : QualityBars::kNone; };
  auto add = [&](const std::string& bar, const std::function<BarRow::Cell(const QualityBars&, const Metrics&)>& cell)
  {
    BarRow row{bar, {}};
    for (size_t s = 0; s < result.setups.size(); ++s)
      row.per_setup.push_back(cell(result.config.setups[s].bars, result.setups[s].per_group.at(group).metrics));
    rows.push_back(row);
  };
  auto relative = [](double v) { return percent(v, 2); };
  auto degrees = [](double v) { return fixed(v, 3) + "°"; };
  auto mm = [](double v) { return fixed(v, 2) + " mm"; };
  const std::string window =
      fixed(100.0 * kInsertionDepthMin, 0) + "-" + fixed(100.0 * kInsertionDepthMax, 0) + " cm of depth";
  add("depth error, median", [&](const QualityBars& b, const Metrics& m)
      { return spreadCell(m.distance_error, m.distance_error.median, limit(b.distance_median_max), relative); });
  add("depth error, 95th percentile", [&](const QualityBars& b, const Metrics& m)
      { return spreadCell(m.distance_error, m.distance_error.p95, limit(b.distance_p95_max), relative); });
  add("lateral error at " + window + ", median", [&](const QualityBars&, const Metrics& m)
      { return spreadCell(m.lateral_error_mm, m.lateral_error_mm.median, QualityBars::kNone, mm); });
  add("lateral error at " + window + ", 95th percentile", [&](const QualityBars& b, const Metrics& m)
      { return spreadCell(m.lateral_error_mm, m.lateral_error_mm.p95, limit(b.lateral_p95_max_mm), mm); });
  add("yaw error, median", [&](const QualityBars&, const Metrics& m)
      { return spreadCell(m.yaw_error_deg, m.yaw_error_deg.median, QualityBars::kNone, degrees); });
  add("yaw error, 95th percentile", [&](const QualityBars& b, const Metrics& m)
      { return spreadCell(m.yaw_error_deg, m.yaw_error_deg.p95, limit(b.yaw_p95_max_deg), degrees); });
  add("axis-angle error, median", [&](const QualityBars&, const Metrics& m)
      { return spreadCell(m.axis_angle_error_deg, m.axis_angle_error_deg.median, QualityBars::kNone, degrees); });
  add("axis-angle error, 95th percentile",
      [&](const QualityBars& b, const Metrics& m) {
        return spreadCell(m.axis_angle_error_deg, m.axis_angle_error_deg.p95, limit(b.axis_angle_p95_max_deg), degrees);
      });
  add("aligned where the puller would touch the bore wall (frames)",
      [&](const QualityBars& b, const Metrics& m) { return countCell(m.unsafe_aligned, limit(b.unsafe_aligned_max)); });
  add("aligned recall (truth aligned: puller clears, 50-60 cm)", [&](const QualityBars& b, const Metrics& m)
      { return rateCell(m.aligned_recall, limit(b.aligned_recall_min), true); });
  add("aligned recall where the puller clears the wall by ≥ " + fixed(kClearRecallSlack * 1000.0, 2) + " mm",
      [&](const QualityBars&, const Metrics& m) { return rateCell(m.aligned_recall_clear, QualityBars::kNone, true); });
  return rows;
}

namespace
{
// One Markdown table per group: `title` and the group's name, a column per setup; the measured
// value first, the verdict and limit only where it is a bar at that setup.
std::string barTables(const EvaluationResult& result, const std::string& title,
                      const std::function<std::vector<BarRow>(const EvaluationResult&, size_t)>& rows_of)
{
  std::ostringstream out;
  for (size_t g = 0; g < result.config.groups.size(); ++g)
  {
    std::vector<std::string> header = {title + ": " + result.config.groups[g].name + " set" +
                                       (result.config.groups[g].sets.size() > 1 ? "s" : "")};
    for (size_t s = 0; s < result.setups.size(); ++s)
      header.push_back(result.config.setups[s].name + " (" + std::to_string(result.setups[s].per_group.at(g).frames) +
                       " frames)");
    std::vector<std::vector<std::string>> rows;
    for (const BarRow& bar : rows_of(result, g))
    {
      std::vector<std::string> row = {bar.bar};
      for (const BarRow::Cell& c : bar.per_setup)
        row.push_back(c.applies ? c.measured + ": " + verdict(c) + " (" + c.limit + ")" : c.measured);
      rows.push_back(row);
    }
    out << (g > 0 ? "\n" : "") << markdownTable(header, rows);
  }
  return out.str();
}
}  // namespace

std::string headlineTable(const EvaluationResult& result)
{
  return barTables(result, "DESIGN.md §7 bar", headlineRows);
}

std::string poseTable(const EvaluationResult& result)
{
  return barTables(result, "Pose and alignment (issue 10)", poseRows);
}

std::string approachTable(const EvaluationResult& result)
{
  auto ratio = [](int n, int of) { return std::to_string(n) + "/" + std::to_string(of); };
  auto median = [](const std::vector<double>& v)
  { return v.empty() ? std::string("-") : fixed(percentile(v, 0.5), 2); };
  // The columns a total and an approach share: published, over 3%, other spool, aligned, touching.
  auto counts = [&](const ApproachTracking& a, std::vector<std::string>& row)
  {
    row.insert(row.end(), {ratio(a.published, a.frames),
                           std::to_string(a.over_3_percent) + " (" + fixed(100.0 * a.max_depth_error, 2) + ")",
                           std::to_string(a.other_spool), ratio(a.aligned_on_truly, a.truly_aligned),
                           std::to_string(a.aligned_touching)});
  };
  std::vector<std::vector<std::string>> totals;
  std::vector<std::vector<std::string>> rows;
  for (std::size_t s = 0; s < result.setups.size(); ++s)
  {
    const std::vector<ApproachTracking>& approaches = result.setups[s].approaches;
    if (approaches.empty())
      continue;
    ApproachTracking sum;
    const std::string& name = result.config.setups[s].name;
    for (const ApproachTracking& a : approaches)
    {
      sum.frames += a.frames;
      sum.published += a.published;
      sum.over_3_percent += a.over_3_percent;
      sum.max_depth_error = std::max(sum.max_depth_error, a.max_depth_error);
      sum.other_spool += a.other_spool;
      sum.truly_aligned += a.truly_aligned;
      sum.aligned_on_truly += a.aligned_on_truly;
      sum.aligned_touching += a.aligned_touching;
      sum.covariance_holds += a.covariance_holds;
      sum.windowed_ms.insert(sum.windowed_ms.end(), a.windowed_ms.begin(), a.windowed_ms.end());
      sum.full_search_ms.insert(sum.full_search_ms.end(), a.full_search_ms.begin(), a.full_search_ms.end());
      std::vector<std::string> row = {name, std::to_string(a.seed)};
      counts(a, row);
      row.push_back(ratio(a.covariance_holds, a.published - a.other_spool));
      rows.push_back(row);
    }
    const int on_target = sum.published - sum.other_spool;
    std::vector<std::string> total = {name, std::to_string(approaches.size())};
    counts(sum, total);
    total.push_back(on_target > 0 ? percent(static_cast<double>(sum.covariance_holds) / on_target) : "-");
    total.push_back(median(sum.windowed_ms) + " / " + median(sum.full_search_ms));
    totals.push_back(total);
  }
  if (totals.empty())
    return "";
  return markdownTable({"setup", "approaches", "published frames", "depth > 3% (max %)", "other spool",
                        "aligned on truly aligned", "aligned, would touch", "3σ holds the truth",
                        "windowed / whole-frame ms, medians"},
                       totals) +
         "\n" +
         markdownTable({"setup", "seed", "published frames", "depth > 3% (max %)", "other spool",
                        "aligned on truly aligned", "aligned, would touch", "3σ holds the truth"},
                       rows);
}

bool barsPass(const EvaluationResult& result, size_t index)
{
  for (size_t g = 0; g < result.config.groups.size(); ++g)
    for (const auto& rows : {headlineRows(result, g), poseRows(result, g)})
      for (const BarRow& bar : rows)
      {
        const BarRow::Cell& c = bar.per_setup.at(index);
        if (c.applies && !c.pass)
          return false;
      }
  return true;
}

namespace
{
// What was rendered and how many frames each setup scored.
std::string introSection(const EvaluationResult& result)
{
  std::ostringstream md;
  const EvaluationConfig& config = result.config;
  std::vector<std::vector<std::string>> counts;
  for (const Setup& setup : config.setups)
    counts.push_back(
        {setup.name, std::to_string(setup.counts.main), std::to_string(setup.counts.negatives),
         std::to_string(setup.counts.hard), std::to_string(setup.counts.distorted),
         std::to_string(setup.counts.oblique), std::to_string(setup.counts.packed),
         std::to_string(setup.counts.packed_oblique),
         toleranceText(holeTolerance(CameraIntrinsics::thesisDefault(setup.size.width, setup.size.height))),
         setup.analyses ? "yes" : "no"});
  md << "# spool_vision evaluation\n\n"
     << "Written by `spool_eval`. Every frame is rendered by `SpoolRenderer` with exact ground truth, from seed "
     << config.seed << ": the main set (as `spool_render --set main`: spools at 50-110 cm and ±20° bearing, all "
     << "four lamp conditions, neighbours, about 15% negatives), the negatives set (empty slots, plates, tape "
     << "rolls, cans), the hard set (real-webcam effects, DESIGN.md §7), the distorted set (a C270-like lens, "
     << "below), the oblique set (the hard set's scenes seen 25-40° off the spool axis), the packed set (the "
     << "hard set's frames on a packed shelf: 1-3 neighbours each side, touching on half the scenes, a back row "
     << "seen through the gaps on seven in ten, which is never the target) and the packed_oblique set (the oblique "
     << "set's scenes on that shelf: neighbours seen 25-40° off their axes overlap the target's flanges). Each "
     << "set is rendered once per size and shared by the setups of that size; the same seed gives the same scenes at "
        "every size, and a setup with "
     << "fewer frames takes the first ones. Controlled poses use " << config.pose_repeats
     << " scene(s) per pose, without neighbours, all lamps on. Times are the detector's own "
     << "(`SpoolDetection::time_ms`), one OpenCV thread, on the machine that ran this (shared machines make them "
     << "noisy).\n\n"
     << markdownTable({"setup", "main frames", "negatives frames", "hard frames", "distorted frames", "oblique frames",
                       "packed frames", "packed_oblique frames", "hole tolerance (front rim)", "thesis analyses"},
                      counts)
     << "\n";

  return md.str();
}

// DESIGN.md §7: the bars per group and setup, and where the flange-eligible frames went.
std::string headlineSection(const EvaluationResult& result)
{
  std::ostringstream md;
  md << "## Headline: DESIGN.md §7\n\n"
     << "One table per group of sets, a column per setup; each cell is the measured value, then the verdict and "
        "the bar where that bar applies at that setup (`default.yaml` bars per resolution as issue 9 sets them, "
        "`seed.yaml` its thesis-reproduction bars).\n\n"
     << headlineTable(result) << "\n"
     << "No heap allocation per frame in steady state is asserted by the gtest "
     << "`SpoolDetector.SteadyStateDoesNotAllocate` (test/core/test_spool_detector.cpp, 640x480), not measured "
     << "here. The slowest frame's time is the least of 3 runs of that frame (a single run on a shared machine "
     << "can be preempted); the median is of single runs.\n\n"
     << "Where the flange-eligible frames went (and the denominators of the rates above); hole errors are of the "
     << "holes reported on a correct flange, against the bore's front rim:\n\n"
     << breakdown(result) << "\n";

  return md.str();
}

// Issue 10: pose and alignment against the 3D truth.
std::string poseSection(const EvaluationResult& result)
{
  std::ostringstream md;
  const std::vector<double>& lens = c270Distortion();
  md << "## Pose and alignment (issue 10)\n\n"
     << "Per group of sets and setup, against the renderer's 3D truth; issue 10's bars apply on the distorted set "
        "at 640x480 (`default.yaml`), elsewhere the values are reported only. The distorted set is the main set's "
        "frames and, every third frame, a pose near the end of an approach (48-62 cm of depth, the puller within "
        "3 mm sideways, 1.5 mm up or down, 0.6° of heading and 0.3° of pitch of the bore axis), rendered through a "
        "C270-like lens: plumb_bob D = ("
     << fixed(lens[0], 4) << ", " << fixed(lens[1], 4) << ", " << fixed(lens[2], 4) << ", " << fixed(lens[3], 4) << ", "
     << fixed(lens[4], 4)
     << "), f = 200 px at 120 rows (800 px at 640x480), principal point -1% of the width and +0.8% of the "
        "height off the image centre; the detector gets that camera, distortion included.\n\n"
     << "- **Depth** error is |measured - true| / true of `distance`, the depth of the bore's front centre; "
        "**yaw** as in the headline; both over correct flanges on flange-eligible frames.\n"
     << "- **Lateral** error is |measured - true| `lateral_offset` (the bore's front centre's x from the puller "
        "axis), **axis-angle** error |measured - true| angle between the spool axis and the puller axis, over "
        "correct flanges on the slot's spool (whose 3D truth is known); lateral only at "
     << fixed(100.0 * kInsertionDepthMin, 0) << "-" << fixed(100.0 * kInsertionDepthMax, 0)
     << " cm of depth. `n` is how many frames had a value; \"not measured\" means the detector left it NaN.\n"
     << "- **Aligned where the puller would touch the bore wall**: frames reported aligned whose truth "
        "`puller_clears` is false (the puller axis more than t_f off the bore axis at the bore's front face or "
        "back end; frames without a spool count too). **Aligned recall**: frames reported aligned of those whose "
        "truth is aligned (`puller_clears` and 50-60 cm of depth). The distorted set's near-alignment frames are "
        "drawn to straddle the wall (about 60% clear it), and a frame a tenth of a millimetre inside it cannot be "
        "told from one a tenth outside without risking the first bar, so the recall is also given over the "
        "truth-aligned frames that clear the wall by at least "
     << fixed(kClearRecallSlack * 1000.0, 2) << " mm (`puller_clearance`, a tenth of t_f).\n\n"
     << poseTable(result) << "\n";

  return md.str();
}

// The scoring rules, in words.
std::string approachSection(const EvaluationResult& result)
{
  const std::string table = approachTable(result);
  if (table.empty())
    return "";
  return "## The tracker over whole approaches (issue 26)\n\n" + std::to_string(result.config.approaches) +
         " `approach_hard` sequences per size (seeds " + std::to_string(result.config.seed * 1000 + 1) + " on), " +
         std::to_string(EvaluationConfig::kApproachFrames) + " frames each at " +
         fixed(EvaluationConfig::kApproachRate, 0) +
         " Hz, followed by `TrackingDetector` with the setup's parameters. A published frame (a track tracking or "
         "coasting) is on another spool when its bore lies 10 cm or more from the target's (x, y); else its depth "
         "error is the relative one and its 3σ check the Mahalanobis distance of the truth's bore front centre "
         "under `position_covariance` (<= 3 for 97.1% of an honest Gaussian). `scripts/evaluate_tracking.py` "
         "measures the same over more seeds, with dropouts and the failing frames.\n\n" +
         table + "\n";
}

std::string scoringSection()
{
  std::ostringstream md;
  md << "## How a frame is scored\n\n"
     << "- **Target**: the spool in front of the robot, i.e. among the rendered spools whose flange centre is in "
        "view (the slot's spool and its neighbours), the one with the smallest |yaw| (bearing from the puller "
        "column). A spool within 1° of that |yaw| is tied with it: the robot may take either, so a detection on it "
        "is correct and measured against it. Frames without any spool centre in view have no target.\n"
     << "- A flange is **correct** when its centre lies within max(3 px, 0.1 r) of the target's projected rim "
        "(ellipse) centre and its radius within 10%. A flange on another spool, or on none, is a **wrong "
        "target**; with no target any flange is a **false spool**.\n"
     << "- A hole is **found** when the flange is correct and the hole lies on the bore's front rim (its projected "
        "ellipse: centre, mean semi-axis) within the setup's tolerance: 1 px for centre and radius at 640x480 "
        "(DESIGN.md §7), the same angle at larger sizes, max(2 px, 0.25 r) and max(1 px, 25%) below 480 rows where "
        "holes are a few pixels wide. Hole truth is known for the slot's spool only, so holes on a neighbour (the "
        "target, or tied with the slot's spool) are neither found nor false.\n"
     << "- **Flange found** counts frames whose target has at least half its rim in view, at 50-110 cm, "
        "within ±20° and seen at most 40° off its own axis (issue 28's obliques; in the oblique set a neighbour "
        "nearer the puller column than the slot's spool is the target, seen up to 60° off); **hole found** those of "
        "them where the target is the slot's spool and the opening is in "
        "view (`hole_in_view`), split into the bore showing through (`bore_visible`) and dark; **wrong target** frames "
        "with a target and another "
        "spool centre in view; **false spool** frames without a spool centre in view.\n"
     << "- Distance error is |measured - true| / true of the depth (z of the bore's front centre in the camera "
        "frame) and yaw error |measured - true|, against the target's own truth, over correct flanges on "
        "flange-eligible frames.\n"
     << "- **Depth more than 10% off** counts every detection on a frame with a target whose depth is that far "
        "off the spool under the found flange's centre (any spool, correct or not: it is what a controller acts "
        "on), split by the found flange's height against that spool's rim: under 0.95 a ring inside the rim (a rib "
        "or inner ring), over 1.05 an outline around it (the joint silhouette of the front and back flanges, a "
        "circle through a neighbour), within 5% the rim itself with a wrong pose; or no spool under it.\n\n";

  return md.str();
}

// The thesis' chapter 4 analyses, their charts appended to `charts`.
std::string chapterFourSection(const EvaluationResult& result, nlohmann::ordered_json& charts)
{
  std::ostringstream md;
  const EvaluationConfig& config = result.config;
  md << "## Thesis chapter 4 on rendered data\n\n"
     << "On the setups marked above; every variant runs on the same frames as the first headline table.\n\n";
  for (const VariantAnalysis& analysis : result.analyses)
  {
    charts.push_back(chart::toJson(variantChart(result, analysis), analysis.key + ".png"));
    md << "### " << analysis.title << "\n\n"
       << analysis.note << "\n\n"
       << variantTable(result, analysis) << "\n![" << analysis.key << "](" << analysis.key << ".png)\n\n";
  }
  const double tolerance =
      config.setups.empty()
          ? 0.0
          : 0.5 * (config.setups[0].params.geometry.hole_diameter - config.setups[0].params.geometry.puller_diameter);
  md << "### Distance (thesis Fig. 4.16)\n\nStraight on (bearing 0, camera 6 cm above the hole axis); measured is "
     << "the mean over the scenes where the flange was found correctly. Thesis: errors up to about 1.6%.\n\n"
     << distanceSection(result, charts) << "\n"
     << "### Yaw (thesis Table 4.1)\n\nThe spool at a known bearing at 80, 90 and 100 cm. Thesis: 0-1.47% error "
     << "for most angles, up to 6% for some.\n\n"
     << yawSection(result, charts) << "\n"
     << "### tx_r near alignment (thesis Fig. 4.17)\n\ntx_r = D·|tan θ| (Eq. 3.8) from the measured D and θ, "
     << "against the clearance t_f. Thesis: tx_r ≤ 0.25 cm within ±0.25° at 50 and 60 cm (0.26 cm at 60 cm, "
     << "0.25°).\n\n"
     << txSection(result, charts, tolerance);
  return md.str();
}

}  // namespace

void writeReport(const EvaluationResult& result, const std::string& dir_name)
{
  const std::filesystem::path dir(dir_name);
  std::filesystem::create_directories(dir);
  std::string md =
      introSection(result) + headlineSection(result) + poseSection(result) + approachSection(result) + scoringSection();
  nlohmann::ordered_json charts = nlohmann::ordered_json::array();
  if (!analysedSetups(result).empty())
    md += chapterFourSection(result, charts);
  write(md, dir / "report.md");
  write(nlohmann::ordered_json{{"charts", charts}}.dump(1) + "\n", dir / "charts.json");
}

}  // namespace spool_vision
