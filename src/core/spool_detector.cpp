#include "spool_vision/spool_detector.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace spool_vision
{
SpoolDetector::SpoolDetector(const DetectorParams& params)
  : params_(params)
  , preprocessor_(params.preprocess)
  , matcher_(params.matcher, params.geometry.hole_diameter / params.geometry.flange_diameter)
{
  validateParams(params);
}

void SpoolDetector::setParams(const DetectorParams& params)
{
  validateParams(params);
  params_ = params;
  preprocessor_.setParams(params.preprocess);
  matcher_ = ConcentricMatcher(params.matcher, params.geometry.hole_diameter / params.geometry.flange_diameter);
  geometry_.reset();
}

void SpoolDetector::setCamera(const CameraIntrinsics& camera)
{
  if (!camera.valid())
    throw std::invalid_argument("camera intrinsics need fx, fy > 0 and a positive image size");
  camera_ = camera;
  geometry_.reset();
}

void SpoolDetector::clearCamera()
{
  camera_.reset();
  geometry_.reset();
}

const SpoolGeometry& SpoolDetector::geometryFor(cv::Size size)
{
  if (geometry_ && geometry_->camera().width == size.width && geometry_->camera().height == size.height)
    return *geometry_;
  using_fallback_ = !(camera_ && camera_->width == size.width && camera_->height == size.height);
  const CameraIntrinsics camera =
      using_fallback_ ? CameraIntrinsics::thesisDefault(size.width, size.height,
                                                        params_.geometry.fallback_focal_length)
                      : *camera_;
  geometry_.emplace(params_.geometry, camera);
  return *geometry_;
}

SpoolDetection SpoolDetector::detect(const cv::Mat& image, PixelFormat format)
{
  if (image.empty())
    throw std::invalid_argument("empty image");
  if (image.cols < kMinImageSide || image.rows < kMinImageSide)
    throw std::invalid_argument("image " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                " is smaller than the minimum " + std::to_string(kMinImageSide) + "x" +
                                std::to_string(kMinImageSide));
  const auto start = std::chrono::steady_clock::now();
  const SpoolGeometry& geometry = geometryFor(image.size());
  const HoughParams& hp = params_.hough;

  preprocessor_.process(image, format, preprocessed_);
  edge_detector_.detect(preprocessed_, hp.edge_threshold, edges_);

  double flange_min = 0.0;
  double flange_max = 0.0;
  double hole_min = 0.0;
  double hole_max = 0.0;
  geometry.radiusRanges(flange_min, flange_max, hole_min, hole_max);
  auto pick = [](double configured, double derived) { return configured > 0.0 ? configured : derived; };

  HoughSearch flange_search;
  flange_search.r_min = pick(hp.flange_radius_min, flange_min);
  flange_search.r_max = pick(hp.flange_radius_max, flange_max);
  flange_search.polarity = hp.flange_polarity;
  flange_search.min_score = 1.0 - hp.sensitivity;
  flange_search.min_visible_fraction = hp.min_visible_fraction;
  flange_search.max_circles = hp.max_candidates;
  flange_hough_.detect(edges_, image.size(), flange_search, flanges_);

  SpoolDetection result;
  const std::optional<Circle> target =
      ConcentricMatcher::selectTarget(flanges_, geometry.reference(geometry.nominalDistance()));
  holes_.clear();
  if (target)
  {
    result.detected = true;
    result.flange = *target;
    result.confidence = target->score;

    HoughSearch hole_search;
    hole_search.polarity = hp.hole_polarity;
    hole_search.min_score = 1.0 - hp.sensitivity;
    hole_search.min_visible_fraction = hp.min_visible_fraction;
    hole_search.max_circles = hp.max_candidates;
    hole_search.r_min = pick(hp.hole_radius_min, hole_min);
    hole_search.r_max = pick(hp.hole_radius_max, hole_max);
    if (params_.matcher.mode == MatchMode::kMcht)
    {
      // The concentric rule lets the hole search look only where a matching hole can be, at
      // the radius the flange implies: a window of a few pixels instead of the whole frame.
      const double tol = params_.matcher.concentric_tolerance;
      hole_search.center_window =
          cv::Rect2d(target->x - tol, target->y - tol, 2.0 * tol + 1e-9, 2.0 * tol + 1e-9);
      const double expected = target->r_vertical * params_.geometry.hole_diameter / params_.geometry.flange_diameter;
      const double spread = params_.matcher.hole_ratio_tolerance * expected;
      hole_search.r_min = std::max({hole_search.r_min, expected - spread, 1.5});
      hole_search.r_max = std::min(hole_search.r_max, expected + spread);
    }
    hole_hough_.detect(edges_, image.size(), hole_search, holes_);
    if (const auto hole = matcher_.matchHole(*target, holes_))
    {
      result.hole_detected = true;
      result.hole = *hole;
    }
  }
  geometry.measure(result);
  result.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace spool_vision
