// Stage 4: distance, yaw, reference point, overlap and alignment (thesis §3.4).
#pragma once

#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// How far (m) the puller's axis passes from the bore's axis at the bore's front and at its back
/// end (bore_length_max along `axis`: the miss along a straight bore is convex in the depth, so a
/// shorter bore clears wherever this one does), for a bore whose front centre is `position`
/// (camera optical frame); the puller runs parallel to the optical axis through
/// (puller_offset_x, puller_offset_y). Thesis Eq. 3.8 taken along the bore.
void pullerMiss(const GeometryParams& params, const cv::Point3d& position, const cv::Vec3d& axis, double& front,
                double& back);

class SpoolGeometry
{
public:
  SpoolGeometry(const GeometryParams& params, const CameraIntrinsics& camera);

  const CameraIntrinsics& camera() const
  {
    return camera_;
  }

  /// m, the flange's diameter (flange_diameter)
  double flangeDiameter() const
  {
    return params_.flange_diameter;
  }

  /// Eq. 3.2 verbatim: f * flange diameter / diameter_px (depth along the axis, m).
  double depthFromDiameter(double diameter_px) const;

  /// The flange rim as a 35 cm circle in 3D, centred on the ray through `centre` (px, the
  /// projection of the bore's front centre: the hole's centre, which stays within ~0.1 px of it):
  /// the depth and the unit normal (spool axis) whose image conic has the rim's measured ellipse
  /// centre and vertical semi-axis. Perspective moves the ellipse centre off the projected centre
  /// by about f (R/Z)^2 n_xy n_z (R the flange radius), so that offset gives the axis, and unlike
  /// the ellipse's eccentricity (1 - cos) it is linear in the angle and has its sign. Gauss-Newton
  /// on the exact conic of a circle (Q = (n.C)^2 I - (n.C)(n C^T + C n^T) + (|C|^2 - R^2) n n^T,
  /// camera optical frame, normalised image coordinates). Starts from Eq. 3.2 and the optical
  /// axis; returns false (outputs untouched) when it does not converge.
  bool rimPose(const Circle& flange, const cv::Point2d& centre, cv::Point3d& position, cv::Vec3d& axis) const;

  /// rimPose() refined on the rim itself: the depth and axis of the 35 cm circle about the ray
  /// through `centre` (px) that best explains `rim`, the flange rim's edge points (px, undistorted
  /// image), starting from `position` and `axis`. Gauss-Newton on each point's distance from the
  /// circle within the circle's plane (scaled to px at the circle's depth); a point more than
  /// max(1.5 px, 1% of the radius) off (three times that in the first pass) is left out (the back flange's crescent
  /// beside an oblique rim, a neighbour touching it). Unlike the ellipse's centre this uses whatever arc shows and the
  /// rim's size and eccentricity too. False (outputs untouched) with fewer than 30 points in the band or without
  /// convergence. `support`, if given, gets how many of the points used lie within the band at the result.
  /// With `centre_reach` (px) positive the circle's centre is fitted too, starting on the ray through
  /// `centre` and ending within that many px of it (false otherwise): a 3-D circle of known radius
  /// has the ellipse's five degrees of freedom. For a bore measured off its centre (a dark bore seen
  /// 30-40 deg off its axis shows part of its opening dark, its fit 3-6 px off at 640x480), where
  /// the fit about its ray leaves too few points in the band.
  bool fitRimPose(const std::vector<cv::Point2f>& rim, const cv::Point2d& centre, cv::Point3d& position,
                  cv::Vec3d& axis, int* support = nullptr, double centre_reach = 0.0) const;

  /// The half-width and half-height (px, undistorted image) of the bore's front rim, a circle of
  /// hole_diameter about `position` (m, camera optical frame) square to the unit `axis`: its
  /// projection to first order about the centre (the pinhole's Jacobian at `position` applied to
  /// the circle's two in-plane directions; the second order is (R/Z)^2 of it, under 0.01 px for a
  /// 3.6 cm bore at 0.45 m and more). Zero where `position` is not in front of the camera or `axis`
  /// is not finite.
  cv::Size2d boreExtent(const cv::Point3d& position, const cv::Vec3d& axis) const;
  /// The same projection as an ellipse: its semi-axes (px) and their tilt (EllipseShape), the
  /// short axis towards `axis`'s vanishing point. Zero-sized where boreExtent() is.
  EllipseShape boreEllipse(const cv::Point3d& position, const cv::Vec3d& axis) const;

  /// The point at `depth` (m) seen at pixel (u, v), camera optical frame (pinhole).
  cv::Point3d backProject(double u, double v, double depth) const;
  /// The undistorted pixel (px) at which `point` (camera optical frame, m, z > 0) is seen
  /// (pinhole): backProject()'s inverse.
  cv::Point2d project(const cv::Point3d& point) const;

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

  /// The image rows [first, second] (px, undistorted) within which a hole centre of a spool at
  /// distance_min..distance_max can be atPullerLevel(): cy + fy * (puller_offset_y -/+
  /// axis_height_tolerance) / depth, each bound at the depth that takes it farthest from cy.
  std::pair<double, double> pullerLevelRows() const;

  /// t_f = (hole - puller) / 2 in metres (0.25 cm for the thesis spool).
  double tolerance() const;

  /// Fills depth (distance), range, position, axis, yaw, reference, lateral offset, overlap and
  /// alignment of `detection` from its flange and (if hole_detected) hole. With a hole the pose
  /// is fitRimPose()'s on `rim` (rimPose()'s where that fails or `rim` is empty); without one, or
  /// where the fit's pose is implausible (its depth more than 15% off Eq. 3.2's, its axis more than
  /// 40 deg off the line of sight), the hole (else flange) centre and Eq. 3.2 give the position
  /// and the axis is NaN (axis_cue none: nothing aligns on it). Aligned: a hole rim, depth in the
  /// insertion window, |yaw| <= aligned_max_yaw and pullerMiss() within t_f at both ends of the bore (Eq. 3.8, taken
  /// along the bore); Rule 3 (overlapped) is reported but not required.
  void measure(SpoolDetection& detection, const std::vector<cv::Point2f>& rim = {}) const;
  /// The hole of a measured `detection` moved (measured again): its position back-projected
  /// through the new hole centre at the same depth, the axis kept, and what measure() derives
  /// from the pose (yaw, reference, lateral offset, overlap, alignment) derived again.
  void moveBoreCentre(SpoolDetection& detection) const;
  /// For a measured `detection` with a hole and no axis (measure() found no plausible pose:
  /// rimPose() diverged from its ellipse, or the fits from it contradict Eq. 3.2): fitRimPose() on
  /// `rim` (its flange rim's edge points, px, undistorted image) from Eq. 3.2's depth and the two
  /// axes, turned about the vertical either way from the line of sight, that the ellipse's aspect
  /// allows (a circle seen acos(r_horizontal / r_vertical) off its axis), each also from 4% nearer
  /// and farther. The plausible fit most of the rim supports, if it keeps kMinAspectSupport of it,
  /// is taken and what measure() derives from the pose derived again; false (untouched) where none.
  bool measureFromAspect(SpoolDetection& detection, const std::vector<cv::Point2f>& rim) const;
  /// measureFromAspect()'s least fraction of the rim within the fit's band
  static constexpr double kMinAspectSupport = 0.5;
  /// No absurd pose (issue 28): the rim fits' depth within kMaxDepthDisagreement of Eq. 3.2's
  /// (`eq32_depth`, m, on the rim's vertical semi-axis) and the axis within kMaxMeasuredViewAngle
  /// of the line of sight (viewAngle()); finite.
  static bool plausiblePose(const cv::Point3d& position, const cv::Vec3d& axis, double eq32_depth);
  /// The angle (rad, 0 to pi/2) between the spool axis `axis` (unit, camera frame) and the line of
  /// sight to `position` (m, camera frame): how far off its axis the spool is seen.
  static double viewAngle(const cv::Point3d& position, const cv::Vec3d& axis);
  /// plausiblePose()'s widest view off the axis (rad): a rim's ellipse is only taken within 20% of
  /// a circle (HoughAccumulator::refine), so no rim seen more than acos(0.8) = 37 deg off its axis
  /// was measured.
  static constexpr double kMaxMeasuredViewAngle = 40.0 * M_PI / 180.0;
  /// plausiblePose()'s largest relative difference between a rim fit's depth and Eq. 3.2's: the
  /// rim's vertical semi-axis gives the depth within a few percent whatever the fit (a cut rim's:
  /// 6%; a pitch of 10 deg: 1.5%).
  static constexpr double kMaxDepthDisagreement = 0.15;

private:
  /// measure()'s quantities that follow from the detection's position and axis.
  void measureFromPose(SpoolDetection& d) const;

  // fitRimPose() from rimPose()'s pose in `d` and from the flange circle's size; keeps the one
  // more of `rim` supports.
  void refineOnRim(const std::vector<cv::Point2f>& rim, SpoolDetection& d) const;

  GeometryParams params_;
  CameraIntrinsics camera_;
};

}  // namespace spool_vision
