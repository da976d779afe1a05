#include "spool_vision/concentric_matcher.h"

#include <cmath>
#include <limits>

namespace spool_vision
{
ConcentricMatcher::ConcentricMatcher(const MatcherParams& params, double hole_to_flange_ratio)
  : params_(params), ratio_(hole_to_flange_ratio)
{
}

bool ConcentricMatcher::accepts(const Circle& flange, const Circle& hole) const
{
  if (params_.mode == MatchMode::kCht)
    return true;
  const double tol = params_.concentric_tolerance;
  if (std::abs(hole.x - flange.x) > tol || std::abs(hole.y - flange.y) > tol)
    return false;
  const double expected = ratio_ * flange.r_vertical;
  return std::abs(hole.r - expected) <= params_.hole_ratio_tolerance * expected;
}

std::optional<Circle> ConcentricMatcher::matchHole(const Circle& flange,
                                                   const std::vector<Circle>& holes) const
{
  std::optional<Circle> best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (const Circle& hole : holes)
  {
    if (!accepts(flange, hole))
      continue;
    // MCHT trusts the concentric geometry; plain CHT (the thesis baseline) takes the strongest.
    const double cost = params_.mode == MatchMode::kMcht ? std::hypot(hole.x - flange.x, hole.y - flange.y)
                                                         : -hole.score;
    if (cost < best_cost)
    {
      best_cost = cost;
      best = hole;
    }
  }
  return best;
}

std::optional<Circle> ConcentricMatcher::selectTarget(const std::vector<Circle>& flanges,
                                                      const cv::Point2d& reference)
{
  std::optional<Circle> best;
  double best_d = std::numeric_limits<double>::infinity();
  for (const Circle& f : flanges)
  {
    const double d = std::hypot(f.x - reference.x, f.y - reference.y);
    if (d < best_d)
    {
      best_d = d;
      best = f;
    }
  }
  return best;
}

}  // namespace spool_vision
