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
  auto take = [&result](const Circle& flange, const std::optional<Circle>& hole)
  {
    result.detected = true;
    result.flange = flange;
    result.confidence = flange.score;
    result.hole_detected = hole.has_value();
    if (hole)
      result.hole = *hole;
  };
  if (params_.matcher.mode == MatchMode::kCht)
  {
    // The thesis baseline: the flange nearest the reference, the strongest hole anywhere.
    if (order_.empty())
      return;
    edge_detector_.extract(hp.hole_edge_threshold, cv::Rect(cv::Point(), preprocessed_.size()), hole_edges_);
    hole_hough_.detect(hole_edges_, preprocessed_.size(), hole_search, holes_);
    const Circle& target = flanges_[order_.front()];
    take(target, matcher_.matchHole(target, holes_));
    return;
  }
  // MCHT: a flange is a spool only with a concentric hole of the right size, so false circles
  // (arcs of neighbours, shelf edges, round objects without a bore) do not become the target.
  // Candidates are tried nearest-first; the hole search looks only where such a hole can be.
  for (const std::size_t i : order_)
  {
    const Circle& flange = flanges_[i];
    HoughSearch search = hole_search;
    if (!matcher_.narrowHoleSearch(flange, preprocessed_.size(), search))
      continue;
    // Only edges that can lie on that hole's rim, at the hole's own threshold.
    const cv::Point2d centre = (search.center_window.tl() + search.center_window.br()) * 0.5;
    const double reach_x = 0.5 * search.center_window.width + search.r_max + 2.0;
    const double reach_y = 0.5 * search.center_window.height + search.r_max + 2.0;
    const cv::Rect window(cvFloor(centre.x - reach_x), cvFloor(centre.y - reach_y), cvCeil(2.0 * reach_x) + 1,
                          cvCeil(2.0 * reach_y) + 1);
    edge_detector_.extract(hp.hole_edge_threshold, window, hole_edges_);
    hole_hough_.detect(hole_edges_, preprocessed_.size(), search, holes_);
    if (const auto hole = matcher_.matchHole(flange, holes_))
    {
      take(flange, hole);
      return;
    }
  }
  holes_.clear();
  if (params_.matcher.spool_evidence == SpoolEvidence::kFlange && !order_.empty())
    take(flanges_[order_.front()], std::nullopt);
}

}  // namespace spool_vision
