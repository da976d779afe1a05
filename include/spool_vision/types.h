// Plain value types shared by every stage of the ROS-free core.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

namespace spool_vision
{
/// Which side of a circle's rim is darker: a dark disc on a brighter background (the flange),
/// a bright disc on a darker background (a lit bore), or either, even changing along the rim
/// (a bore's front rim: bright where the see-through lens touches it, dark elsewhere).
enum class Polarity
{
  kDark,
  kBright,
  kAny
};

/// A circle in pixel coordinates (OpenCV convention: (0,0) is the centre of the top-left pixel).
struct Circle
{
  double x = 0.0;
  double y = 0.0;
  double r = 0.0;
  /// Vertical semi-axis of the fitted rim (px); equals r for a fronto-parallel circle. The
  /// vertical extent of a circle at depth Z is exact under yaw, so distance uses this.
  double r_vertical = 0.0;
  /// Horizontal semi-axis of the fitted rim (px): shorter than r_vertical when the rim is seen
  /// from the side (its spool yawed); 0 where no fit gave one (then r).
  double r_horizontal = 0.0;
  /// Fraction of the in-frame rim supported by edge pixels, 0..1.
  double score = 0.0;
  /// Fraction of the rim that lies inside the image, 0..1.
  double visible_fraction = 0.0;
};

/// An ellipse's shape about its centre (px): semi-axes `semi_x` and `semi_y` along the image's x
/// and y axes turned by `tilt` (rad, from x towards y; 0: axis-aligned). A circle seen off its
/// axis and off the image centre projects to one whose short axis points at the axis's vanishing
/// point, so tilted where the two are not level (SpoolGeometry::boreEllipse()).
struct EllipseShape
{
  double semi_x = 0.0;
  double semi_y = 0.0;
  double tilt = 0.0;

  /// The shape scaled by `s` (same tilt).
  EllipseShape scaled(double s) const
  {
    return {s * semi_x, s * semi_y, tilt};
  }
  /// Half the width of the ellipse's bounding box (px).
  double halfWidth() const
  {
    return std::hypot(semi_x * std::cos(tilt), semi_y * std::sin(tilt));
  }
  /// Half the height of the ellipse's bounding box (px): its vertical extent, as Circle::r_vertical.
  double halfHeight() const
  {
    return std::hypot(semi_x * std::sin(tilt), semi_y * std::cos(tilt));
  }
};

/// The camera of the frames the detector gets: pinhole intrinsics (px) of an image of
/// width x height and its lens distortion, as ROS's image_geometry::PinholeCameraModel reads a
/// sensor_msgs/CameraInfo: a raw image is K with D, a rectified one P with no distortion; binning
/// and ROI already applied (K of the delivered image, D unchanged: it acts on normalised
/// coordinates).
struct CameraIntrinsics
{
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  int width = 0;
  int height = 0;
  /// OpenCV's order, which is ROS's: plumb_bob (k1, k2, p1, p2, k3) or rational_polynomial
  /// (k1, k2, p1, p2, k3, k4, k5, k6); empty or all zero = an undistorted (or rectified) image.
  std::vector<double> distortion;

  /// Positive finite focal lengths, a finite principal point, a positive size and a distortion
  /// vector of a length OpenCV's model takes, all finite (a YAML `.inf` must not pass).
  bool valid() const
  {
    auto finite = [](double v) { return std::isfinite(v); };
    return fx > 0.0 && fy > 0.0 && finite(fx) && finite(fy) && finite(cx) && finite(cy) && width > 0 && height > 0 &&
           (distortion.empty() || distortion.size() == 4 || distortion.size() == 5 || distortion.size() == 8) &&
           std::all_of(distortion.begin(), distortion.end(), finite);
  }

  /// True when the image must be undistorted before it is measured.
  bool distorted() const
  {
    return std::any_of(distortion.begin(), distortion.end(), [](double d) { return d != 0.0; });
  }

  bool operator==(const CameraIntrinsics& o) const
  {
    return fx == o.fx && fy == o.fy && cx == o.cx && cy == o.cy && width == o.width && height == o.height &&
           distortion == o.distortion;
  }
  bool operator!=(const CameraIntrinsics& o) const
  {
    return !(*this == o);
  }

  /// The thesis camera (C270: f = 200 px at 120 rows) scaled to an image of the given size,
  /// principal point at the image centre. `focal_at_120_rows` lets a config override 200 px.
  static CameraIntrinsics thesisDefault(int width, int height, double focal_at_120_rows = 200.0)
  {
    CameraIntrinsics k;
    k.fx = k.fy = focal_at_120_rows * height / 120.0;
    k.cx = (width - 1) / 2.0;
    k.cy = (height - 1) / 2.0;
    k.width = width;
    k.height = height;
    return k;
  }
};

/// Pixel layout of an input frame (cv::Mat does not carry the channel order).
enum class PixelFormat
{
  kMono8,
  kMono16,
  kBgr8,
  kRgb8,
  kBgra8,
  kRgba8
};

/// The cv::Mat type a frame of `format` has.
inline int matTypeOf(PixelFormat format)
{
  switch (format)
  {
    case PixelFormat::kMono8:
      return CV_8UC1;
    case PixelFormat::kMono16:
      return CV_16UC1;
    case PixelFormat::kBgr8:
    case PixelFormat::kRgb8:
      return CV_8UC3;
    case PixelFormat::kBgra8:
    case PixelFormat::kRgba8:
      return CV_8UC4;
  }
  return -1;
}

/// The rim a track predicts: a circle of `radius` (m) about `centre` (m, camera optical frame,
/// REP 103) in the plane normal to `axis` (unit; NaN: facing the camera).
struct RimPrediction
{
  cv::Point3d centre;
  cv::Vec3d axis;
  double radius = 0.0;  ///< 0: no prediction
};

/// Where a followed spool's flange will be (SpoolTracker::flangeWindow), for
/// SpoolDetector::detect(): pixels of the undistorted image (the frame without lens distortion).
struct FlangeWindow
{
  cv::Point2d centre;          ///< the flange rim's centre (px)
  double centre_margin = 0.0;  ///< px either way, in x and y
  double radius = 0.0;         ///< the flange rim's vertical semi-axis (px)
  double radius_margin = 0.0;  ///< px either way
  /// The whole rim, for a measurement by moving edges along it (MovingEdges) instead of a Hough
  /// search of the window; none (radius 0) in a window without a track's pose
  RimPrediction rim;
  double rim_reach = 0.0;   ///< px each way along the rim's normal the moving edges search
  double bore_reach = 0.0;  ///< px: 3 sigma of where the bore's front centre shows, plus a px
  /// The window stands for the whole frame (a target hint's area, not a track's prediction): the
  /// whole frame's checks of the chosen spool apply in it (a rib ring taken for the flange)
  bool whole_frame = false;
  /// The spool's axis (unit, camera optical frame, into the spool) where the caller already
  /// measured it (an inner ring of the same spool seen far off its axis): the window's bore is
  /// measured with its lit wall on the side this axis gives. NaN: the window's own pose's.
  cv::Vec3d spool_axis{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
                       std::numeric_limits<double>::quiet_NaN()};
};

/// What the detector reports for one frame. Undefined numbers are NaN, never stale values.
struct SpoolDetection
{
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  bool detected = false;       ///< flange found
  bool hole_detected = false;  ///< a hole that passed the matcher
  bool overlapped = false;     ///< flange and hole centres on the reference point (Rule 3)
  /// Safe to insert: a hole rim, in the insertion window, |yaw| small, and the puller's axis
  /// within tolerance of the bore's axis at the bore's front and back ends (SpoolGeometry::measure)
  bool aligned = false;
  /// m, depth: z of the bore's front centre in the camera optical frame (thesis Eq. 3.2)
  double distance = kNaN;
  double range = kNaN;  ///< m, optical centre to the bore's front centre
  double yaw = kNaN;    ///< rad, positive when the spool appears right of the reference
  /// m, x of the bore's front centre relative to the puller axis, camera optical frame (Eq. 3.8)
  double lateral_offset = kNaN;
  double tolerance = 0.0;  ///< m, t_f = (hole - puller) / 2
  /// m, the bore's front centre in the camera optical frame (REP 103: x right, y down, z forward)
  cv::Point3d position{kNaN, kNaN, kNaN};
  /// Unit vector along the spool axis, from the front face into the spool, camera optical frame
  cv::Vec3d axis{kNaN, kNaN, kNaN};
  double axis_angle = kNaN;  ///< rad, between the spool axis and the puller axis (optical z)
  /// rad, atan2(axis.x, axis.z): positive when the axis, followed into the spool, heads right
  double axis_yaw = kNaN;
  double confidence = 0.0;  ///< 0..1: with a hole 0.5 + 0.5 * min(rim scores), flange alone 0.5 * its score
  Circle flange;
  Circle hole;  ///< the bore's front rim
  /// Near the spool axis the lit wall shows through the bore only where its front and back
  /// openings overlap: a bright lens inside the front rim, shifted off its centre by the parallax
  /// of the ~20 cm bore (thesis Fig. 3.3: the two rims share a centre only on the axis).
  bool lens_detected = false;
  Circle lens;
  /// The spool axis from the bore's parallax (bore_parallax.h), when the lit lens shows inside
  /// the hole rim and agrees with the two openings' model: the lens's centroid (px), the axis's
  /// slopes (x/z, y/z, camera optical frame) and their covariance (rad^2). The per-frame `axis`
  /// stays the rim's; SpoolTracker fuses both.
  bool parallax_measured = false;
  cv::Point2d lens_centroid{kNaN, kNaN};
  cv::Vec2d parallax_slopes{kNaN, kNaN};
  cv::Matx22d parallax_covariance = cv::Matx22d::zeros();
  cv::Point2d reference;  ///< px, where the puller axis appears
  double time_ms = 0.0;   ///< detector processing time for this frame
};

}  // namespace spool_vision
