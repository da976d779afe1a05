#include "spool_vision/concentric_matcher.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace spool_vision
{
ConcentricMatcher::ConcentricMatcher(const MatcherParams& params, const GeometryParams& spool,
                                     const CameraIntrinsics& camera)
  : params_(params)
  , ratio_(spool.hole_diameter / spool.flange_diameter)
  , focal_length_(camera.fy)
  , tolerance_px_(params.concentric_tolerance * camera.fy)
{
  if (params.mode == MatchMode::kMcht)
    back_ = {{camera.cx, camera.cy}, spool.hub_length / (camera.fy * 0.5 * spool.flange_diameter)};
}

cv::Size2d ConcentricMatcher::centreTolerance(const Circle& flange) const
{
  const double drift = flange.r_vertical * flange.r_vertical / focal_length_;
  return {tolerance_px_ + drift * std::tan(params_.max_view_angle),
          tolerance_px_ + drift * std::tan(params_.max_view_pitch)};
}

double ConcentricMatcher::axisShift(const Circle& flange) const
{
  if (!(flange.r_horizontal > 0.0) || flange.r_horizontal >= flange.r_vertical)
    return 0.0;
  // A rim turned by psi about the vertical: cos(psi) = r_h / r_v, and its ellipse centre moves
  // f (R/Z)^2 sin(psi) cos(psi) = r_v^2 / f sin(psi) cos(psi) off the axis (SpoolGeometry::rimPose).
  const double c = flange.r_horizontal / flange.r_vertical;
  // Below ~10 degrees the rim is within 1.5% of round, which a fit on a blurred or partly hidden
  // rim does not resolve: the shift would follow the fit's noise.
  constexpr double kMinTurnCos = 0.985;
  if (c > kMinTurnCos)
    return 0.0;
  return flange.r_vertical * flange.r_vertical / focal_length_ * std::sqrt(1.0 - c * c) * c;
}

cv::Size2d ConcentricMatcher::silhouetteShift(const Circle& flange) const
{
  const double depth_ratio = backToFront(flange) - 1.0;
  return {std::abs(flange.x - back_.principal_point.x) * depth_ratio,
          std::abs(flange.y - back_.principal_point.y) * depth_ratio};
}

double ConcentricMatcher::backToFront(const Circle& flange) const
{
  return 1.0 / back_.scale(flange.r_vertical);
}

bool ConcentricMatcher::narrowHoleSearch(const Circle& flange, cv::Size image_size, HoughSearch& search) const
{
  const cv::Size2d tol = centreTolerance(flange);
  const cv::Size2d shift = silhouetteShift(flange);
  // Outward is away from the principal point on each axis.
  const double left = tol.width + (flange.x < back_.principal_point.x ? shift.width : 0.0);
  const double right = tol.width + (flange.x < back_.principal_point.x ? 0.0 : shift.width);
  const double up = tol.height + (flange.y < back_.principal_point.y ? shift.height : 0.0);
  const double down = tol.height + (flange.y < back_.principal_point.y ? 0.0 : shift.height);
  // Pixel centres are integers: the image spans -0.5 .. size - 0.5.
  search.center_window = cv::Rect2d(flange.x - left, flange.y - up, left + right + 1e-9, up + down + 1e-9) &
                         cv::Rect2d(-0.5, -0.5, image_size.width, image_size.height);
  const double expected = holeRadius(flange);
  const double spread = params_.hole_ratio_tolerance * expected;
  search.r_min = std::max({search.r_min, expected - spread, 1.5});
  search.r_max = std::min(search.r_max, (expected + spread) * backToFront(flange));
  return !search.center_window.empty() && search.r_min <= search.r_max;
}

bool ConcentricMatcher::explainsFit(const Circle& front, const Circle& fit) const
{
  const double k = back_.scale(front.r_vertical);
  const cv::Point2d back = back_.principal_point + k * (cv::Point2d(front.x, front.y) - back_.principal_point);
  const cv::Size2d tol = centreTolerance(front);
  auto between = [](double v, double a, double b, double slack)
  { return v >= std::min(a, b) - slack && v <= std::max(a, b) + slack; };
  constexpr double kRadiusSlack = 0.1;
  return between(fit.x, front.x, back.x, tol.width) && between(fit.y, front.y, back.y, tol.height) &&
         fit.r_vertical >= (1.0 - kRadiusSlack) * k * front.r_vertical &&
         fit.r_vertical <= (1.0 + kRadiusSlack) * front.r_vertical;
}

bool ConcentricMatcher::accepts(const Circle& flange, const Circle& hole) const
{
  if (params_.mode == MatchMode::kCht)
    return true;
  // The bore's front rim must be (nearly) whole in view: a spool whose axis is at the frame
  // border is not in front of the robot, and half a small "rim" at the border is any edge.
  if (hole.visible_fraction < kMinHoleVisibleFraction)
    return false;
  const cv::Size2d tol = centreTolerance(flange);
  if (std::abs(hole.x - flange.x) > tol.width || std::abs(hole.y - flange.y) > tol.height)
    return false;
  const double expected = holeRadius(flange);
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
    // MCHT trusts the concentric geometry: the hole nearest where the spool's axis should
    // show, of the size the flange gives it (a rib around the bore is concentric too, but larger);
    // plain CHT (the thesis baseline) takes the strongest.
    const double shift = axisShift(flange);
    const double cost = params_.mode == MatchMode::kMcht
                            ? std::min(std::hypot(hole.x - flange.x - shift, hole.y - flange.y),
                                       std::hypot(hole.x - flange.x + shift, hole.y - flange.y)) +
                                  std::abs(hole.r - holeRadius(flange))
                            : -hole.score;
    if (cost < best_cost)
    {
      best_cost = cost;
      best = hole;
    }
  }
  return best;
}

double ConcentricMatcher::targetCost(const cv::Point2d& centre, double score, const cv::Point2d& reference)
{
  // Arcs of several objects can fake a weak circle right in the middle of the frame: one half as
  // well supported as a solid rim must be twice as near to win.
  return std::hypot(centre.x - reference.x, centre.y - reference.y) / std::clamp(score / kSolidRimScore, 1e-3, 1.0);
}

void ConcentricMatcher::dropEnclosingGhosts(std::vector<Circle>& flanges, const std::vector<Circle>& others)
{
  auto encloses = [](const Circle& ghost, const Circle& rim)
  {
    const double offset = std::hypot(rim.x - ghost.x, rim.y - ghost.y);
    return rim.score >= kSolidRimScore && rim.score > ghost.score && rim.r < ghost.r && offset > 0.1 * ghost.r &&
           offset + 0.5 * rim.r < ghost.r;
  };
  // Judged on the whole list before any is removed (max_candidates <= 64; no allocation).
  std::uint64_t ghosts = 0;
  const std::size_t n = std::min<std::size_t>(flanges.size(), 64);
  for (std::size_t i = 0; i < n; ++i)
  {
    const auto ghost = [&](const Circle& rim) { return encloses(flanges[i], rim); };
    if (std::any_of(flanges.begin(), flanges.end(), ghost) || std::any_of(others.begin(), others.end(), ghost))
      ghosts |= std::uint64_t{1} << i;
  }
  std::size_t kept = 0;
  for (std::size_t i = 0; i < flanges.size(); ++i)
    if (i >= n || !(ghosts >> i & 1U))
      flanges[kept++] = flanges[i];
  flanges.resize(kept);
}

void ConcentricMatcher::orderByReference(const std::vector<Circle>& flanges, const cv::Point2d& reference,
                                         std::vector<std::size_t>& order)
{
  order.clear();
  for (std::size_t i = 0; i < flanges.size(); ++i)
    order.push_back(i);
  auto cost = [&](std::size_t i) { return targetCost({flanges[i].x, flanges[i].y}, flanges[i].score, reference); };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cost(a) < cost(b); });
}

}  // namespace spool_vision
