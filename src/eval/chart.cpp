#include "chart.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace spool_vision::chart
{
namespace
{
constexpr int kWidth = 900;
constexpr int kHeight = 540;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kSmall = 0.42;
const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kInk(40, 40, 40);
const cv::Scalar kGrid(228, 228, 228);
const cv::Scalar kLevelInk(60, 60, 200);

cv::Scalar colour(size_t i)
{
  // Tableau 10, BGR.
  static const cv::Scalar palette[] = {{180, 119, 31},  {14, 127, 255}, {44, 160, 44},   {40, 39, 214},
                                       {189, 103, 148}, {75, 86, 140},  {194, 119, 227}, {127, 127, 127},
                                       {34, 189, 188},  {207, 190, 23}};
  return palette[i % (sizeof(palette) / sizeof(palette[0]))];
}

/// Draws `s` with its anchor at `at`: h -1/0/1 = left/centre/right, v -1/0/1 = top/middle/bottom.
void label(cv::Mat& img, const std::string& s, cv::Point at, int h, int v, double scale = kSmall,
           const cv::Scalar& ink = kInk)
{
  int base = 0;
  const cv::Size size = cv::getTextSize(s, kFont, scale, 1, &base);
  const int x = at.x - (h + 1) * size.width / 2;
  const int y = at.y + (1 - v) * size.height / 2;
  cv::putText(img, s, {x, y}, kFont, scale, ink, 1, cv::LINE_AA);
}

// Fewest decimals that show `step` exactly.
int decimalsFor(double step)
{
  for (int d = 0; d < 6; ++d)
  {
    const double scaled = step * std::pow(10.0, d);
    if (std::abs(scaled - std::round(scaled)) < 1e-6 * std::max(1.0, scaled))
      return d;
  }
  return 6;
}

std::string format(double v, int decimals)
{
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

void dashed(cv::Mat& img, cv::Point a, cv::Point b, const cv::Scalar& ink)
{
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  for (double s = 0.0; s < length; s += 13.0)
  {
    const double e = std::min(s + 8.0, length);
    auto at = [&](double t)
    { return cv::Point(cvRound(a.x + (b.x - a.x) * t / length), cvRound(a.y + (b.y - a.y) * t / length)); };
    cv::line(img, at(s), at(e), ink, 1, cv::LINE_AA);
  }
}

// The plot area and its data ranges.
struct Frame
{
  cv::Rect area;
  double x0 = 0.0;
  double x1 = 1.0;
  double y0 = 0.0;
  double y1 = 1.0;

  double px(double x) const
  {
    return area.x + (x - x0) / (x1 - x0) * area.width;
  }
  double py(double y) const
  {
    return area.y + area.height - (y - y0) / (y1 - y0) * area.height;
  }
  cv::Point at(double x, double y) const
  {
    return {cvRound(px(x)), cvRound(py(y))};
  }
};

struct LegendEntry
{
  std::string label;
  cv::Scalar ink;
  enum Kind
  {
    kLine,
    kMarker,
    kBar,
    kLevel
  } kind;
};

void marker(cv::Mat& img, cv::Point p, const cv::Scalar& ink)
{
  cv::circle(img, p, 4, ink, cv::FILLED, cv::LINE_AA);
}

// Title on top, legend rows below it; returns the y where the plot area may start.
int header(cv::Mat& img, const std::string& title, const std::vector<LegendEntry>& legend)
{
  label(img, title, {kWidth / 2, 18}, 0, 0, 0.6);
  int x = 70;
  int y = 44;
  for (const LegendEntry& e : legend)
  {
    int base = 0;
    const int width = cv::getTextSize(e.label, kFont, kSmall, 1, &base).width + 42;
    if (x + width > kWidth - 10)
    {
      x = 70;
      y += 20;
    }
    const cv::Point mid(x + 12, y);
    switch (e.kind)
    {
      case LegendEntry::kLine:
        cv::line(img, mid - cv::Point(10, 0), mid + cv::Point(10, 0), e.ink, 2, cv::LINE_AA);
        marker(img, mid, e.ink);
        break;
      case LegendEntry::kMarker:
        marker(img, mid, e.ink);
        break;
      case LegendEntry::kBar:
        cv::rectangle(img, mid - cv::Point(8, 6), mid + cv::Point(8, 6), e.ink, cv::FILLED);
        break;
      case LegendEntry::kLevel:
        dashed(img, mid - cv::Point(10, 0), mid + cv::Point(10, 0), e.ink);
        break;
    }
    label(img, e.label, {x + 28, y}, -1, 0);
    x += width;
  }
  return y + 22;
}

// Grid, y ticks, axes and the axis titles (x ticks are the caller's).
void axes(cv::Mat& img, const Frame& f, const std::vector<double>& y_ticks, const std::string& x_label,
          const std::string& y_label)
{
  const int decimals = y_ticks.size() > 1 ? decimalsFor(y_ticks[1] - y_ticks[0]) : 0;
  for (double t : y_ticks)
  {
    const int y = cvRound(f.py(t));
    cv::line(img, {f.area.x, y}, {f.area.x + f.area.width, y}, kGrid, 1);
    cv::line(img, {f.area.x - 5, y}, {f.area.x, y}, kInk, 1);
    label(img, format(t, decimals), {f.area.x - 8, y}, 1, 0);
  }
  cv::line(img, f.area.tl(), {f.area.x, f.area.y + f.area.height}, kInk, 1);
  cv::line(img, {f.area.x, f.area.y + f.area.height}, f.area.br(), kInk, 1);
  label(img, x_label, {f.area.x + f.area.width / 2, kHeight - 12}, 0, 1, 0.5);

  int base = 0;
  const cv::Size size = cv::getTextSize(y_label, kFont, 0.5, 1, &base);
  cv::Mat text(size.height + base + 4, size.width + 4, CV_8UC3, kWhite);
  cv::putText(text, y_label, {2, size.height + 2}, kFont, 0.5, kInk, 1, cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(text, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int top = std::clamp(f.area.y + f.area.height / 2 - rotated.rows / 2, 0, kHeight - rotated.rows);
  if (rotated.rows <= kHeight)
    rotated.copyTo(img(cv::Rect(4, top, rotated.cols, rotated.rows)));
}

void levels(cv::Mat& img, const Frame& f, const std::vector<Level>& lines)
{
  for (const Level& l : lines)
  {
    const int y = cvRound(f.py(l.y));
    dashed(img, {f.area.x, y}, {f.area.x + f.area.width, y}, kLevelInk);
    label(img, l.label, {f.area.x + f.area.width - 4, y - 4}, 1, 1, kSmall, kLevelInk);
  }
}

void extend(double v, double& lo, double& hi)
{
  if (std::isfinite(v))
  {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
}
}  // namespace

std::vector<double> ticks(double lo, double hi, int approx_count)
{
  if (!(hi > lo))
    hi = lo + 1.0;
  const double raw = (hi - lo) / std::max(1, approx_count);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * magnitude;
  for (double m : {1.0, 2.0, 2.5, 5.0})
    if (m * magnitude >= raw * (1.0 - 1e-9))
    {
      step = m * magnitude;
      break;
    }
  std::vector<double> out;
  const double first = std::floor(lo / step + 1e-9) * step;
  const double last = std::ceil(hi / step - 1e-9) * step;
  for (double t = first; t <= last + 0.5 * step; t += step)
    out.push_back(t);
  return out;
}

cv::Mat draw(const LineChart& chart)
{
  cv::Mat img(kHeight, kWidth, CV_8UC3, kWhite);
  std::vector<LegendEntry> legend;
  double x_lo = INFINITY;
  double x_hi = -INFINITY;
  double y_lo = INFINITY;
  double y_hi = -INFINITY;
  for (size_t i = 0; i < chart.series.size(); ++i)
  {
    const Series& s = chart.series[i];
    legend.push_back({s.label, colour(i), s.line ? LegendEntry::kLine : LegendEntry::kMarker});
    for (size_t k = 0; k < s.x.size(); ++k)
      if (std::isfinite(s.y[k]))
      {
        extend(s.x[k], x_lo, x_hi);
        extend(s.y[k], y_lo, y_hi);
      }
  }
  for (const Level& l : chart.levels)
  {
    legend.push_back({l.label, kLevelInk, LegendEntry::kLevel});
    extend(l.y, y_lo, y_hi);
  }
  // Nothing to draw on an axis: a unit range.
  if (!std::isfinite(x_lo))
  {
    x_lo = 0.0;
    x_hi = 1.0;
  }
  if (!std::isfinite(y_lo))
  {
    y_lo = 0.0;
    y_hi = 1.0;
  }
  const std::vector<double> x_ticks = ticks(x_lo, x_hi, 8);
  const std::vector<double> y_ticks = ticks(y_lo, y_hi, 6);

  const int top = header(img, chart.title, legend);
  Frame f;
  f.area = cv::Rect(80, top + 6, kWidth - 80 - 25, kHeight - 60 - (top + 6));
  f.x0 = x_ticks.front();
  f.x1 = x_ticks.back();
  f.y0 = y_ticks.front();
  f.y1 = y_ticks.back();
  axes(img, f, y_ticks, chart.x_label, chart.y_label);
  const int x_decimals = x_ticks.size() > 1 ? decimalsFor(x_ticks[1] - x_ticks[0]) : 0;
  for (double t : x_ticks)
  {
    const int x = cvRound(f.px(t));
    const int bottom = f.area.y + f.area.height;
    cv::line(img, {x, bottom}, {x, bottom + 5}, kInk, 1);
    label(img, format(t, x_decimals), {x, bottom + 8}, 0, -1);
  }
  levels(img, f, chart.levels);
  for (size_t i = 0; i < chart.series.size(); ++i)
  {
    const Series& s = chart.series[i];
    for (size_t k = 0; k < s.x.size(); ++k)
    {
      if (!std::isfinite(s.y[k]))
        continue;
      if (s.line && k > 0 && std::isfinite(s.y[k - 1]))
        cv::line(img, f.at(s.x[k - 1], s.y[k - 1]), f.at(s.x[k], s.y[k]), colour(i), 2, cv::LINE_AA);
      marker(img, f.at(s.x[k], s.y[k]), colour(i));
    }
  }
  return img;
}

cv::Mat draw(const BarChart& chart)
{
  cv::Mat img(kHeight, kWidth, CV_8UC3, kWhite);
  std::vector<LegendEntry> legend;
  double y_lo = 0.0;
  double y_hi = std::isfinite(chart.y_max) ? chart.y_max : 0.0;
  for (size_t g = 0; g < chart.groups.size(); ++g)
  {
    legend.push_back({chart.groups[g].label, colour(g), LegendEntry::kBar});
    for (double v : chart.groups[g].values)
      extend(v, y_lo, y_hi);
  }
  for (const Level& l : chart.levels)
  {
    legend.push_back({l.label, kLevelInk, LegendEntry::kLevel});
    extend(l.y, y_lo, y_hi);
  }
  const std::vector<double> y_ticks = ticks(y_lo, y_hi, 6);

  const int top = header(img, chart.title, legend);
  Frame f;
  f.area = cv::Rect(80, top + 6, kWidth - 80 - 25, kHeight - 80 - (top + 6));
  f.y0 = y_ticks.front();
  f.y1 = y_ticks.back();
  axes(img, f, y_ticks, "", chart.y_label);
  const int value_decimals = y_ticks.size() > 1 ? decimalsFor(y_ticks[1] - y_ticks[0]) + 1 : 1;

  const size_t n = std::max<size_t>(1, chart.categories.size());
  const double slot = static_cast<double>(f.area.width) / n;
  const double bar = 0.8 * slot / std::max<size_t>(1, chart.groups.size());
  for (size_t c = 0; c < chart.categories.size(); ++c)
  {
    const double left = f.area.x + c * slot + 0.1 * slot;
    for (size_t g = 0; g < chart.groups.size(); ++g)
    {
      const double v = c < chart.groups[g].values.size() ? chart.groups[g].values[c] : NAN;
      if (!std::isfinite(v))
        continue;
      const int x0 = cvRound(left + g * bar);
      const int x1 = cvRound(left + (g + 1) * bar) - 2;
      const int y_base = cvRound(f.py(std::max(0.0, f.y0)));
      const int y_value = cvRound(f.py(v));
      cv::rectangle(img, {x0, std::min(y_base, y_value)}, {x1, std::max(y_base, y_value)}, colour(g), cv::FILLED);
      if (bar >= 24)
        label(img, format(v, value_decimals), {(x0 + x1) / 2, std::min(y_base, y_value) - 3}, 0, 1, 0.33);
    }
    // Category names under the axis, broken at spaces into lines that fit the slot.
    std::vector<std::string> lines{""};
    std::string word;
    const std::string& name = chart.categories[c];
    for (size_t i = 0; i <= name.size(); ++i)
    {
      if (i < name.size() && name[i] != ' ')
      {
        word += name[i];
        continue;
      }
      const std::string joined = lines.back().empty() ? word : lines.back() + " " + word;
      int base = 0;
      if (!lines.back().empty() && cv::getTextSize(joined, kFont, kSmall, 1, &base).width > slot - 4)
        lines.push_back(word);
      else
        lines.back() = joined;
      word.clear();
    }
    const int centre = cvRound(f.area.x + (c + 0.5) * slot);
    for (size_t l = 0; l < lines.size(); ++l)
      label(img, lines[l], {centre, f.area.y + f.area.height + 8 + static_cast<int>(l) * 16}, 0, -1);
  }
  levels(img, f, chart.levels);
  return img;
}

}  // namespace spool_vision::chart
