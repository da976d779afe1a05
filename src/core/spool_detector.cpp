#include "spool_vision/spool_detector.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace spool_vision
{
SpoolDetector::SpoolDetector(const DetectorParams& params)
  : params_(params), preprocessor_(params.preprocess), matcher_(params.matcher, holeToFlangeRatio())
{
  validateParams(params);
}

void SpoolDetector::setParams(const DetectorParams& params)
{
  validateParams(params);
  params_ = params;
  preprocessor_.setParams(params.preprocess);
  matcher_ = ConcentricMatcher(params.matcher, holeToFlangeRatio());
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
      using_fallback_ ? CameraIntrinsics::thesisDefault(size.width, size.height, params_.geometry.fallback_focal_length)
                      : *camera_;
  geometry_.emplace(params_.geometry, camera);
  matcher_ = ConcentricMatcher(params_.matcher, holeToFlangeRatio(), camera.fy);
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
  selectTarget(geometry.reference(geometry.nominalDistance()), pick(hp.hole_radius_min, hole_min),
               pick(hp.hole_radius_max, hole_max), result);
  geometry.measure(result);
  result.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void SpoolDetector::selectTarget(const cv::Point2d& reference, double hole_min, double hole_max, SpoolDetection& result)
{
  const HoughParams& hp = params_.hough;
  HoughSearch hole_search;
  hole_search.polarity = hp.hole_polarity;
  hole_search.min_score = 1.0 - hp.hole_sensitivity;
  hole_search.min_visible_fraction = hp.min_visible_fraction;
  hole_search.max_circles = hp.max_candidates;
  hole_search.r_min = hole_min;
  hole_search.r_max = hole_max;

  ConcentricMatcher::orderByReference(flanges_, reference, order_);
  holes_.clear();
  if (params_.matcher.mode == MatchMode::kCht)
  {
    // The thesis baseline: the flange nearest the reference, the strongest hole anywhere.
    if (order_.empty())
      return;
    const Circle& target = flanges_[order_.front()];
    result.detected = true;
    result.flange = target;
    result.confidence = target.score;
    edge_detector_.extract(hp.hole_edge_threshold, cv::Rect(cv::Point(), preprocessed_.size()), hole_edges_);
    hole_hough_.detect(hole_edges_, preprocessed_.size(), hole_search, holes_);
    if (const auto hole = matcher_.matchHole(target, holes_))
    {
      result.hole_detected = true;
      result.hole = *hole;
    }
    return;
  }
  // MCHT: a flange is a spool only with a concentric hole of the right size, so false circles
  // (arcs of neighbours, shelf edges, round objects without a bore) do not become the target.
  // Candidates are tried nearest-first; the hole search looks only in the concentric window,
  // at the radius the flange implies.
  const double ratio = holeToFlangeRatio();
  for (const std::size_t i : order_)
  {
    const Circle& flange = flanges_[i];
    const cv::Size2d tol = matcher_.centreTolerance(flange);
    HoughSearch search = hole_search;
    // The hole centre must be in the frame: a spool whose axis is out of view is not in front
    // of the robot, however much of its flange shows.
    search.center_window =
        cv::Rect2d(flange.x - tol.width, flange.y - tol.height, 2.0 * tol.width + 1e-9, 2.0 * tol.height + 1e-9) &
        cv::Rect2d(0.0, 0.0, preprocessed_.cols, preprocessed_.rows);
    if (search.center_window.empty())
      continue;
    const double expected = flange.r_vertical * ratio;
    const double spread = params_.matcher.hole_ratio_tolerance * expected;
    search.r_min = std::max({search.r_min, expected - spread, 1.5});
    search.r_max = std::min(search.r_max, expected + spread);
    if (search.r_min > search.r_max)
      continue;
    // Only edges that can lie on a concentric hole's rim, at the hole's own threshold.
    const double reach_x = tol.width + search.r_max + 2.0;
    const double reach_y = tol.height + search.r_max + 2.0;
    const cv::Rect window(cvFloor(flange.x - reach_x), cvFloor(flange.y - reach_y), cvCeil(2.0 * reach_x) + 1,
                          cvCeil(2.0 * reach_y) + 1);
    edge_detector_.extract(hp.hole_edge_threshold, window, hole_edges_);
    hole_hough_.detect(hole_edges_, preprocessed_.size(), search, holes_);
    if (const auto hole = matcher_.matchHole(flange, holes_))
    {
      result.detected = true;
      result.flange = flange;
      result.confidence = flange.score;
      result.hole_detected = true;
      result.hole = *hole;
      return;
    }
  }
  holes_.clear();
  if (params_.matcher.spool_evidence == SpoolEvidence::kFlange && !order_.empty())
  {
    const Circle& target = flanges_[order_.front()];
    result.detected = true;
    result.flange = target;
    result.confidence = target.score;
  }
}

}  // namespace spool_vision
