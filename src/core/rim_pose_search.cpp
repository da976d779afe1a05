#include "spool_vision/rim_pose_search.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

namespace spool_vision
{
void RimPoseSearch::setCamera(const CameraIntrinsics& camera)
{
  moving_edges_.setCamera(camera);
}

bool RimPoseSearch::measure(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                            const cv::Point2d& bore, const cv::Point3d& position, const cv::Vec3d& axis,
                            const RimSearch& search, RimPoseFit& fit)
{
  return measurePose(image, format, geometry, bore, position, axis, search, 0.0, fit);
}

bool RimPoseSearch::measurePose(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                const cv::Point2d& bore, const cv::Point3d& position, const cv::Vec3d& axis,
                                const RimSearch& search, double off_centre, RimPoseFit& fit)
{
  const bool facing = !(std::isfinite(axis[0]) && std::isfinite(axis[1]) && std::isfinite(axis[2]));
  const cv::Vec3d start = facing ? cv::Vec3d(0.0, 0.0, 1.0) : axis;
  Circle rim;
  const bool measured = moving_edges_.measure(
      image, format, RimPrediction{position, start, 0.5 * geometry.flangeDiameter()}, search, rim);
  sparse_in_view_ = sparse_in_view_ || moving_edges_.sparseInView();
  if (!measured)
    return false;
  // From the depth at which the prediction's size matches the edges' (the rim fit's first band is
  // a few px: a rim 7% larger than predicted lies outside it).
  cv::Point3d fitted = position / moving_edges_.fittedScale();
  cv::Vec3d fitted_axis = start;
  int support = 0;
  // About the bore's ray first; where that leaves too few edges in the band, the centre is fitted
  // too (a dark bore seen far off its axis is measured a few px off its centre).
  if (!geometry.fitRimPose(moving_edges_.rimEdges(), bore, fitted, fitted_axis, &support) &&
      !(off_centre > 0.0 &&
        geometry.fitRimPose(moving_edges_.rimEdges(), bore, fitted, fitted_axis, &support, off_centre * rim.r)))
    return false;
  fit.position = fitted;
  fit.axis = fitted_axis;
  fit.rim = rim;
  fit.support = std::min(1.0, static_cast<double>(support) /
                                  static_cast<double>(std::max<std::size_t>(1, moving_edges_.samplesInFrame())));
  fit.edges.assign(moving_edges_.rimEdges().begin(), moving_edges_.rimEdges().end());
  return true;
}

bool RimPoseSearch::search(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                           const cv::Point2d& bore, double nearest, double farthest, const RimSearch& search,
                           RimPoseFit& best, std::size_t fallback, bool in_view_retry)
{
  const CameraIntrinsics& camera = geometry.camera();
  return searchYaws(image, format, geometry, bore, nearest, farthest, search,
                    std::atan((bore.x - camera.cx) / camera.fx),
                    static_cast<int>(std::floor(kMaxViewAngle / kYawStep + 1e-9)), kRefined, fallback, kBoreOffCentre,
                    in_view_retry, best);
}

bool RimPoseSearch::searchAbout(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                                const cv::Point2d& bore, double nearest, double farthest, const RimSearch& search,
                                double axis_yaw, double half_range, RimPoseFit& best, std::size_t fallback,
                                double off_centre)
{
  return searchYaws(image, format, geometry, bore, nearest, farthest, search, axis_yaw,
                    static_cast<int>(std::floor(half_range / kYawStep + 1e-9)), kRefinedAbout, fallback, off_centre,
                    false, best);
}

bool RimPoseSearch::searchYaws(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                               const cv::Point2d& bore, double nearest, double farthest, const RimSearch& search,
                               double centre_yaw, int turns, std::size_t refined, std::size_t fallback,
                               double off_centre, bool in_view_retry, RimPoseFit& best)
{
  const CameraIntrinsics& camera = geometry.camera();
  const cv::Point3d ray((bore.x - camera.cx) / camera.fx, (bore.y - camera.cy) / camera.fy, 1.0);
  const double line_of_sight = std::atan2(ray.x, ray.z);
  // Every pose reads the same frame: its gray levels are converted once.
  const bool held = moving_edges_.holdsFrame();
  if (!held)
    moving_edges_.beginFrame();
  // The `refined` poses whose moving edges cover most of the rim.
  std::array<CoarsePose, std::max(kRefined, kRefinedAbout)> kept{};
  const auto top = kept.begin();
  const auto top_end = top + static_cast<std::ptrdiff_t>(std::min(refined, kept.size()));
  RimSearch coarse = search;
  coarse.max_samples = kCoarseSamples;
  coarse_.clear();
  // From `nearest` to `farthest` inclusive, at most kDepthStep apart.
  const int steps =
      std::max(1, static_cast<int>(std::ceil(std::log(farthest / nearest) / std::log(kDepthStep) - 1e-9)));
  for (int step = 0; step <= steps; ++step)
  {
    const double depth = nearest * std::pow(farthest / nearest, static_cast<double>(step) / steps);
    const cv::Point3d centre = ray * depth;
    for (int k = -turns; k <= turns; ++k)
    {
      const double yaw = centre_yaw + k * kYawStep;
      if (std::abs(yaw - line_of_sight) > kWidestViewAngle + 1e-9)
        continue;
      Circle rim;
      if (!moving_edges_.measure(
              image, format,
              RimPrediction{centre, cv::Vec3d(std::sin(yaw), 0.0, std::cos(yaw)), 0.5 * geometry.flangeDiameter()},
              coarse, rim))
        continue;
      CoarsePose pose{rim.score, depth, yaw};
      coarse_.push_back(pose);
      for (auto it = top; it != top_end; ++it)
        if (pose.score > it->score)
          std::swap(pose, *it);
    }
  }
  // A face the frame cuts near the camera keeps 25-50 of the 96 samples of its rim, and the 3-D fit
  // asks for 30 in its band: with in_view_retry, where no pose fits, they are all measured again,
  // and the rims outside the one found, with as many samples in the frame as a whole rim has.
  RimSearch measured = search;
  bool found = false;
  sparse_in_view_ = false;
  // (A retry where no rim was cut short would measure the same samples again.)
  for (int pass = 0; pass < (in_view_retry ? 2 : 1) && !found && (pass == 0 || sparse_in_view_); ++pass)
  {
    measured.samples_in_view = search.samples_in_view || pass == 1;
    for (auto it = top; it != top_end; ++it)
      found = fitPose(image, format, geometry, bore, ray, *it, measured, off_centre, found, best);
    if (found || fallback == 0)
      continue;
    // The rim borders its own back flange along a third of it and covers fewer of its coarse
    // samples than the rib rings inside it, which the 3-D fit refuses: the next `fallback` best are
    // fitted. Best covered first, equal scores in the order scanned (depth, then yaw, rising).
    if (pass == 0)
    {
      ranked_.assign(coarse_.begin(), coarse_.end());
      std::sort(ranked_.begin(), ranked_.end(),
                [](const CoarsePose& a, const CoarsePose& b)
                { return std::tie(b.score, a.depth, a.yaw) < std::tie(a.score, b.depth, b.yaw); });
    }
    std::size_t tried = 0;
    for (auto pose = ranked_.begin(); pose != ranked_.end() && tried < fallback; ++pose)
    {
      if (std::any_of(top, top_end,
                      [&](const CoarsePose& kept_pose)
                      { return kept_pose.depth == pose->depth && kept_pose.yaw == pose->yaw; }))
        continue;
      ++tried;
      found = fitPose(image, format, geometry, bore, ray, *pose, measured, off_centre, found, best);
    }
  }
  if (found)
  {
    // A ribbed face's rings cover their coarse samples as fully as the rim does, and the rib may
    // win on the mirrored axis, where outermost() finds no rim outside it (oblique seed 37 #19: the
    // rib at 1.2 m scored 1.0, the rim at 0.82 m 0.84): the nearest pose that covers nearly as
    // much of its rim is measured too.
    const CoarsePose* outer = nullptr;
    for (const CoarsePose& pose : coarse_)
      if (pose.score >= kOuterCoarseShare * top->score &&
          (!outer || pose.depth < outer->depth || (pose.depth == outer->depth && pose.score > outer->score)))
        outer = &pose;
    const bool kept_already = !outer || std::any_of(top, top_end,
                                                    [&](const CoarsePose& pose)
                                                    { return pose.depth == outer->depth && pose.yaw == outer->yaw; });
    if (!kept_already &&
        measurePose(image, format, geometry, bore, ray * outer->depth,
                    cv::Vec3d(std::sin(outer->yaw), 0.0, std::cos(outer->yaw)), measured, off_centre, candidate_) &&
        outside(candidate_, best))
      best = candidate_;
    outermost(image, format, geometry, bore, measured, off_centre, best);
  }
  if (!held)
    moving_edges_.endFrame();
  return found;
}

bool RimPoseSearch::fitPose(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                            const cv::Point2d& bore, const cv::Point3d& ray, const CoarsePose& pose,
                            const RimSearch& search, double off_centre, bool found, RimPoseFit& best)
{
  if (!(pose.score > 0.0))
    return found;
  if (!measurePose(image, format, geometry, bore, ray * pose.depth,
                   cv::Vec3d(std::sin(pose.yaw), 0.0, std::cos(pose.yaw)), search, off_centre, candidate_) ||
      (found && !(candidate_.support > best.support)))
    return found;
  best = candidate_;  // a copy: each keeps its grown capacity
  return true;
}

bool RimPoseSearch::outside(const RimPoseFit& outer, const RimPoseFit& inner)
{
  return outer.position.z < inner.position.z / std::sqrt(kDepthStep) && outer.support >= kOuterSupport * inner.support;
}

void RimPoseSearch::outermost(const cv::Mat& image, PixelFormat format, const SpoolGeometry& geometry,
                              const cv::Point2d& bore, const RimSearch& search, double off_centre, RimPoseFit& best)
{
  const cv::Point3d ray = best.position / best.position.z;
  const cv::Vec3d axis = best.axis;
  const double inner = best.position.z;
  const int steps = static_cast<int>(std::floor(std::log(kInnerRing) / std::log(kDepthStep)));
  for (int step = 1; step <= steps; ++step)
  {
    const double depth = inner / std::pow(kDepthStep, step);
    // Only a rim that stays nearer than the one inside (the moving edges reach back to it from
    // the first step out) and that is as solid counts.
    if (measurePose(image, format, geometry, bore, ray * depth, axis, search, off_centre, candidate_) &&
        outside(candidate_, best))
      best = candidate_;
  }
}

}  // namespace spool_vision
