#include "spool_vision/spool_geometry.h"

#include <cmath>

#include <Eigen/Core>

namespace spool_vision
{
SpoolGeometry::SpoolGeometry(const GeometryParams& params, const CameraIntrinsics& camera)
  : params_(params), camera_(camera)
{
}

double SpoolGeometry::depthFromDiameter(double diameter_px) const
{
  return camera_.fy * params_.flange_diameter / diameter_px;
}

double SpoolGeometry::distance(double u, double v, double r_vertical) const
{
  // Eq. 3.2 gives the depth of the flange centre; the range follows along its viewing ray.
  const double depth = depthFromDiameter(2.0 * r_vertical);
  const Eigen::Vector3d ray((u - camera_.cx) / camera_.fx, (v - camera_.cy) / camera_.fy, 1.0);
  return depth * ray.norm();
}

double SpoolGeometry::yaw(double u, double u_ref) const
{
  if (params_.yaw_mode == YawMode::kLinearFov)
  {
    // Eq. 3.4/3.5: a fixed angle per pixel along the image diagonal (0.3 deg/px at 160x120).
    const double per_px = params_.field_of_view / std::hypot(camera_.width, camera_.height);
    return per_px * (u - u_ref);
  }
  return std::atan2(u - u_ref, camera_.fx);
}

double SpoolGeometry::axisHeightOffset(const Circle& flange, double v) const
{
  const double depth = depthFromDiameter(2.0 * flange.r_vertical);
  return (v - camera_.cy) / camera_.fy * depth - params_.puller_offset_y;
}

bool SpoolGeometry::atPullerLevel(const Circle& flange, double v) const
{
  return std::abs(axisHeightOffset(flange, v)) <= params_.axis_height_tolerance;
}

cv::Point2d SpoolGeometry::reference(double distance) const
{
  if (params_.reference_mode == ReferenceMode::kFixed)
    return {params_.reference_x, params_.reference_y};
  // The puller axis is parallel to the optical axis, offset in the camera frame.
  return {camera_.cx + camera_.fx * params_.puller_offset_x / distance,
          camera_.cy + camera_.fy * params_.puller_offset_y / distance};
}

double SpoolGeometry::nominalDistance() const
{
  return 0.5 * (params_.aligned_distance_min + params_.aligned_distance_max);
}

void SpoolGeometry::radiusRanges(double& flange_min, double& flange_max, double& hole_min, double& hole_max) const
{
  const double f = camera_.fy;
  flange_min = f * params_.flange_diameter / 2.0 / params_.distance_max;
  flange_max = f * params_.flange_diameter / 2.0 / params_.distance_min;
  hole_min = f * params_.hole_diameter / 2.0 / params_.distance_max;
  hole_max = f * params_.hole_diameter / 2.0 / params_.distance_min;
}

double SpoolGeometry::tolerance() const
{
  return (params_.hole_diameter - params_.puller_diameter) / 2.0;
}

void SpoolGeometry::measure(SpoolDetection& d) const
{
  d.tolerance = tolerance();
  if (!d.detected)
  {
    d.reference = reference(nominalDistance());
    return;
  }
  d.distance = distance(d.flange.x, d.flange.y, d.flange.r_vertical);
  // The puller reference is placed at the flange's depth, where the hole is.
  const double depth = depthFromDiameter(2.0 * d.flange.r_vertical);
  d.reference = reference(depth);
  // Under perspective the flange rim's ellipse centre drifts from the spool's true centre
  // (about f R^2 sin(b) cos(b) / Z^2); the small hole's centre stays within ~0.1 px of it.
  d.yaw = yaw(d.hole_detected ? d.hole.x : d.flange.x, d.reference.x);
  d.lateral_offset = d.distance * std::tan(d.yaw);

  const double tol = params_.overlap_tolerance * camera_.fy;
  auto on_reference = [&](const Circle& c)
  { return std::abs(c.x - d.reference.x) <= tol && std::abs(c.y - d.reference.y) <= tol; };
  d.overlapped = d.hole_detected && on_reference(d.flange) && on_reference(d.hole);
  d.aligned = d.overlapped && std::abs(d.yaw) <= params_.aligned_max_yaw && std::abs(d.lateral_offset) <= d.tolerance &&
              d.distance >= params_.aligned_distance_min && d.distance <= params_.aligned_distance_max;
}

}  // namespace spool_vision
