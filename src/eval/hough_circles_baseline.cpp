#include <algorithm>
#include <chrono>

#include <opencv2/imgproc.hpp>

#include "spool_vision/eval/evaluation.h"
#include "spool_vision/spool_geometry.h"

namespace spool_vision
{
RadiusRanges searchRadii(const DetectorParams& params, const CameraIntrinsics& camera)
{
  RadiusRanges derived;
  SpoolGeometry(params.geometry, camera)
      .radiusRanges(derived.flange_min, derived.flange_max, derived.hole_min, derived.hole_max);
  auto pick = [](double configured, double from_distance) { return configured > 0.0 ? configured : from_distance; };
  const HoughParams& h = params.hough;
  return {pick(h.flange_radius_min, derived.flange_min), pick(h.flange_radius_max, derived.flange_max),
          pick(h.hole_radius_min, derived.hole_min), pick(h.hole_radius_max, derived.hole_max)};
}

HoughCirclesBaseline::HoughCirclesBaseline(const RadiusRanges& radii)
  : flange_min_(cvFloor(radii.flange_min))
  , flange_max_(cvCeil(radii.flange_max))
  , hole_min_(std::max(1, cvFloor(radii.hole_min)))
  , hole_max_(cvCeil(radii.hole_max))
{
}

void HoughCirclesBaseline::detect(const cv::Mat& bgr)
{
  cv::cvtColor(bgr, gray_, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(gray_, blurred_, cv::Size(), 1.5);
  cv::HoughCircles(blurred_, flanges_, cv::HOUGH_GRADIENT, 2, flange_min_, 100, 30, flange_min_, flange_max_);
  cv::HoughCircles(blurred_, holes_, cv::HOUGH_GRADIENT, 1, hole_min_, 100, 15, hole_min_, hole_max_);
}

double baselineMedianMs(HoughCirclesBaseline& baseline, const std::vector<RenderedFrame>& frames)
{
  std::vector<double> times;
  times.reserve(frames.size());
  for (const RenderedFrame& frame : frames)
  {
    const auto start = std::chrono::steady_clock::now();
    baseline.detect(frame.image);
    times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  return percentile(times, 0.5);
}

}  // namespace spool_vision
