#include "spool_vision/overlay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "spool_vision/preprocessor.h"

namespace spool_vision
{
namespace
{
const cv::Scalar kRed(0, 0, 255);
const cv::Scalar kBlue(255, 0, 0);
const cv::Scalar kGreen(0, 255, 0);
const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kBlack(0, 0, 0);

// Fixed-point drawing keeps sub-pixel centres (OpenCV draws integer coordinates otherwise).
constexpr int kShift = 4;
constexpr double kScale = 1 << kShift;

cv::Point fixedPoint(double x, double y)
{
  return cv::Point(static_cast<int>(std::lround(x * kScale)), static_cast<int>(std::lround(y * kScale)));
}

// The rim as measured: an axis-aligned ellipse where the fit gave both semi-axes (a flange seen off
// its axis is narrower than it is high), else the circle.
void drawCircle(cv::Mat& bgr, const Circle& c, const cv::Scalar& color, int thickness)
{
  const double semi_x = c.r_horizontal > 0.0 ? c.r_horizontal : c.r;
  const double semi_y = c.r_vertical > 0.0 ? c.r_vertical : c.r;
  cv::ellipse(bgr, fixedPoint(c.x, c.y),
              cv::Size(static_cast<int>(std::lround(semi_x * kScale)), static_cast<int>(std::lround(semi_y * kScale))),
              0.0, 0.0, 360.0, color, thickness, cv::LINE_AA, kShift);
}

// Text with a dark outline stays readable on the black flange and on a bright background.
void drawLabel(cv::Mat& bgr, const std::string& text, int line, double font_scale, int thickness,
               const cv::Scalar& color)
{
  const int baseline_step = static_cast<int>(std::ceil(22.0 * font_scale)) + 2;
  const cv::Point origin(4, 4 + baseline_step * (line + 1) - baseline_step / 4);
  cv::putText(bgr, text, origin, cv::FONT_HERSHEY_SIMPLEX, font_scale, kBlack, thickness + 2, cv::LINE_AA);
  cv::putText(bgr, text, origin, cv::FONT_HERSHEY_SIMPLEX, font_scale, color, thickness, cv::LINE_AA);
}

}  // namespace

void drawOverlay(cv::Mat& bgr, const SpoolDetection& detection)
{
  // Sizes follow the image height so 160x120 (thesis) and 640x480 frames look alike.
  const double unit = bgr.rows / 480.0;
  const int thickness = std::max(1, static_cast<int>(std::lround(2.0 * unit)));
  const double font_scale = std::max(0.3, 0.6 * unit);
  const int font_thickness = std::max(1, static_cast<int>(std::lround(1.5 * unit)));

  if (detection.detected)
    drawCircle(bgr, detection.flange, kRed, thickness);
  if (detection.hole_detected)
    drawCircle(bgr, detection.hole, kBlue, thickness);
  if (std::isfinite(detection.reference.x) && std::isfinite(detection.reference.y))
  {
    const double arm = std::max(4.0, 12.0 * unit);
    const double x = detection.reference.x;
    const double y = detection.reference.y;
    cv::line(bgr, fixedPoint(x - arm, y), fixedPoint(x + arm, y), kGreen, thickness, cv::LINE_AA, kShift);
    cv::line(bgr, fixedPoint(x, y - arm), fixedPoint(x, y + arm), kGreen, thickness, cv::LINE_AA, kShift);
  }

  int line = 0;
  if (!detection.detected)
  {
    drawLabel(bgr, "No spool", line, font_scale, font_thickness, kWhite);
    return;
  }
  char text[64];
  std::snprintf(text, sizeof(text), "Distance: %.1f cm", detection.distance * 100.0);
  drawLabel(bgr, text, line++, font_scale, font_thickness, kWhite);
  std::snprintf(text, sizeof(text), "Angle: %.2f deg", detection.yaw * 180.0 / M_PI);
  drawLabel(bgr, text, line++, font_scale, font_thickness, kWhite);
  if (detection.overlapped)
    drawLabel(bgr, "Center overlapped", line++, font_scale, font_thickness, kGreen);
  if (detection.aligned)
    drawLabel(bgr, "Spool & camera aligned", line++, font_scale, font_thickness, kGreen);
}

cv::Mat renderOverlay(const cv::Mat& image, PixelFormat format, const SpoolDetection& detection)
{
  cv::Mat bgr;
  Preprocessor::toBgr(image, format, bgr);  // the detector's own conversions: one path
  drawOverlay(bgr, detection);
  return bgr;
}

}  // namespace spool_vision
