#include "spool_vision/concentric_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace spool_vision
{
ConcentricMatcher::ConcentricMatcher(const MatcherParams& params, double hole_to_flange_ratio, double focal_length)
  : params_(params), ratio_(hole_to_flange_ratio), focal_length_(focal_length)
{
}

cv::Size2d ConcentricMatcher::centreTolerance(const Circle& flange) const
{
  const double drift = focal_length_ > 0.0 ? flange.r_vertical * flange.r_vertical / focal_length_ : 0.0;
  return {params_.concentric_tolerance + drift * std::tan(params_.max_view_angle),
          params_.concentric_tolerance + drift * std::tan(params_.max_view_pitch)};
}

bool ConcentricMatcher::narrowHoleSearch(const Circle& flange, cv::Size image_size, HoughSearch& search) const
{
  const cv::Size2d tol = centreTolerance(flange);
  search.center_window =
      cv::Rect2d(flange.x - tol.width, flange.y - tol.height, 2.0 * tol.width + 1e-9, 2.0 * tol.height + 1e-9) &
      cv::Rect2d(0.0, 0.0, image_size.width, image_size.height);
  const double expected = ratio_ * flange.r_vertical;
  const double spread = params_.hole_ratio_tolerance * expected;
  search.r_min = std::max({search.r_min, expected - spread, 1.5});
  search.r_max = std::min(search.r_max, expected + spread);
  return !search.center_window.empty() && search.r_min <= search.r_max;
}

bool ConcentricMatcher::accepts(const Circle& flange, const Circle& hole) const
{
  if (params_.mode == MatchMode::kCht)
    return true;
  const cv::Size2d tol = centreTolerance(flange);
  if (std::abs(hole.x - flange.x) > tol.width || std::abs(hole.y - flange.y) > tol.height)
    return false;
  const double expected = ratio_ * flange.r_vertical;
  return std::abs(hole.r - expected) <= params_.hole_ratio_tolerance * expected;
}

std::optional<Circle> ConcentricMatcher::matchHole(const Circle& flange, const std::vector<Circle>& holes) const
{
  std::optional<Circle> best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (const Circle& hole : holes)
  {
    if (!accepts(flange, hole))
      continue;
    // MCHT trusts the concentric geometry; plain CHT (the thesis baseline) takes the strongest.
    const double cost =
        params_.mode == MatchMode::kMcht ? std::hypot(hole.x - flange.x, hole.y - flange.y) : -hole.score;
    if (cost < best_cost)
    {
      best_cost = cost;
      best = hole;
    }
  }
  return best;
}

void ConcentricMatcher::orderByReference(const std::vector<Circle>& flanges, const cv::Point2d& reference,
                                         std::vector<std::size_t>& order)
{
  order.clear();
  for (std::size_t i = 0; i < flanges.size(); ++i)
    order.push_back(i);
  // Distance weighted by support: arcs of several objects can fake a weak circle right in the
  // middle of the frame, and a candidate half as well supported must be twice as close to win.
  auto cost = [&](std::size_t i)
  { return std::hypot(flanges[i].x - reference.x, flanges[i].y - reference.y) / std::max(flanges[i].score, 1e-3); };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cost(a) < cost(b); });
}

}  // namespace spool_vision
