// Stage 4: distance, yaw, reference point, overlap and alignment (thesis §3.4).
#pragma once

#include <optional>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/types.h"

namespace spool_vision
{
class SpoolGeometry
{
public:
  SpoolGeometry(const GeometryParams& params, const CameraIntrinsics& camera);

  const CameraIntrinsics& camera() const
  {
    return camera_;
  }

  /// Range (m) from the optical centre to a flange seen with vertical semi-axis `r_vertical`
  /// (px) centred at (u, v): Eq. 3.2 with the calibrated focal length, corrected for the ray
  /// angle. Uses the vertical extent because it is exact under yaw and survives a rim cut at
  /// the left or right border.
  double distance(double u, double v, double r_vertical) const;

  /// Eq. 3.2 verbatim: f * flange diameter / diameter_px (depth along the axis, m).
  double depthFromDiameter(double diameter_px) const;

  /// Yaw (rad) of a flange centred at column u, relative to the reference column.
  /// pinhole: atan((u - u_ref) / fx); linear_fov: FOV / sqrt(w^2 + h^2) * (u - u_ref).
  double yaw(double u, double u_ref) const;

  /// Where the puller axis appears (px) for a spool at `distance` (m); fixed mode ignores it.
  cv::Point2d reference(double distance) const;

  /// Distance in metres where the radius ranges and the undetected reference are evaluated.
  double nominalDistance() const;

  /// Radius ranges (px) of flange and hole implied by the distance range and focal length.
  void radiusRanges(double& flange_min, double& flange_max, double& hole_min, double& hole_max) const;

  /// How far (m, camera frame y, positive down) the axis of a spool whose flange is `flange`
  /// lies below the puller axis, its hole centre at image row `v`: depth from the flange (Eq.
  /// 3.2), then y = (v - cy) / fy * depth, minus puller_offset_y.
  double axisHeightOffset(const Circle& flange, double v) const;

  /// True when that offset is within axis_height_tolerance: a round thing far above or below
  /// the puller's level (a ring on the wall, a can on the board) is no spool to pick.
  bool atPullerLevel(const Circle& flange, double v) const;

  /// t_f = (hole - puller) / 2 in metres (0.25 cm for the thesis spool).
  double tolerance() const;

  /// Fills distance, yaw, reference, lateral offset, overlap and alignment of `detection`
  /// from its flange and (if hole_detected) hole.
  void measure(SpoolDetection& detection) const;

private:
  GeometryParams params_;
  CameraIntrinsics camera_;
};

}  // namespace spool_vision
