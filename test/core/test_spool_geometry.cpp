#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "spool_vision/spool_geometry.h"

using spool_vision::CameraIntrinsics;
using spool_vision::GeometryParams;
using spool_vision::ReferenceMode;
using spool_vision::SpoolDetection;
using spool_vision::SpoolGeometry;
using spool_vision::YawMode;

namespace
{
constexpr double kDeg = M_PI / 180.0;
const CameraIntrinsics kThesis = CameraIntrinsics::thesisDefault(160, 120);
}  // namespace

TEST(SpoolGeometry, ThesisCameraIs200PxAt120RowsAnd800At480)
{
  EXPECT_DOUBLE_EQ(kThesis.fx, 200.0);
  EXPECT_DOUBLE_EQ(kThesis.cx, 79.5);
  EXPECT_DOUBLE_EQ(kThesis.cy, 59.5);
  EXPECT_DOUBLE_EQ(CameraIntrinsics::thesisDefault(640, 480).fy, 800.0);
}

TEST(SpoolGeometry, Equation32DepthFromDiameter)
{
  const SpoolGeometry g(GeometryParams(), kThesis);
  // D = FL * ROH * FH / (SH * OH) = 0.4 * 35 * 120 / (0.24 * 70) = 100 cm.
  EXPECT_NEAR(g.depthFromDiameter(70.0), 1.0, 1e-12);
  // Appendix B, first row: 53.09 px at 160x120 -> 131.85 cm (measured 133 cm).
  EXPECT_NEAR(g.depthFromDiameter(53.09), 1.3185, 1e-4);
}

TEST(SpoolGeometry, LinearFovYawIsThreeTenthsOfADegreePerPixel)
{
  GeometryParams p;
  p.yaw_mode = YawMode::kLinearFov;
  p.field_of_view = 60.0 * kDeg;
  const SpoolGeometry g(p, kThesis);
  EXPECT_NEAR(g.yaw(90.0, 80.0) / kDeg, 3.0, 1e-12);  // 60 / sqrt(160^2 + 120^2) = 0.3 deg/px
  EXPECT_NEAR(g.yaw(70.0, 80.0) / kDeg, -3.0, 1e-12);
}

TEST(SpoolGeometry, PinholeYawIsTheRayAngle)
{
  const SpoolGeometry g(GeometryParams(), kThesis);
  EXPECT_NEAR(g.yaw(100.0, 80.0), std::atan(20.0 / 200.0), 1e-12);
  EXPECT_GT(g.yaw(81.0, 80.0), 0.0);  // right of the reference is positive
}

TEST(SpoolGeometry, ProjectIsBackProjectsInverse)
{
  // An off-centre principal point and unequal focal lengths, so that a swapped axis shows.
  CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  camera.fy = 790.0;
  camera.cx = 331.5;
  camera.cy = 231.5;
  const SpoolGeometry g(GeometryParams(), camera);
  // A point 0.1 m right, 0.05 m down at 0.8 m: fx X / Z + cx = 800 * 0.125 + 331.5.
  const cv::Point2d seen = g.project({0.1, 0.05, 0.8});
  EXPECT_NEAR(seen.x, 431.5, 1e-9);
  EXPECT_NEAR(seen.y, 231.5 + 790.0 * 0.0625, 1e-9);
  for (const cv::Point2d& pixel : {cv::Point2d(0.0, 0.0), cv::Point2d(639.0, 17.25), cv::Point2d(12.5, 470.0)})
  {
    const cv::Point2d back = g.project(g.backProject(pixel.x, pixel.y, 0.63));
    EXPECT_NEAR(back.x, pixel.x, 1e-9);
    EXPECT_NEAR(back.y, pixel.y, 1e-9);
  }
}

TEST(SpoolGeometry, ReferencePoint)
{
  GeometryParams p;
  const SpoolGeometry puller(p, kThesis);
  // 6 cm below the camera at 60 cm: 200 * 0.06 / 0.6 = 20 px below the principal point.
  EXPECT_NEAR(puller.reference(0.6).x, 79.5, 1e-12);
  EXPECT_NEAR(puller.reference(0.6).y, 79.5, 1e-12);
  p.reference_mode = ReferenceMode::kFixed;
  const SpoolGeometry fixed(p, kThesis);
  EXPECT_EQ(fixed.reference(0.6), cv::Point2d(80, 50));
}

TEST(SpoolGeometry, ToleranceIsAQuarterCentimetre)
{
  EXPECT_NEAR(SpoolGeometry(GeometryParams(), kThesis).tolerance(), 0.0025, 1e-12);
}

TEST(SpoolGeometry, RadiusRangesFollowTheDistanceRange)
{
  GeometryParams p;
  p.distance_min = 0.5;
  p.distance_max = 1.1;
  double fmin = 0;
  double fmax = 0;
  double hmin = 0;
  double hmax = 0;
  SpoolGeometry(p, kThesis).radiusRanges(fmin, fmax, hmin, hmax);
  EXPECT_NEAR(fmin, 200 * 0.175 / 1.1, 1e-9);
  EXPECT_NEAR(fmax, 70.0, 1e-9);
  EXPECT_NEAR(hmin, 200 * 0.018 / 1.1, 1e-9);
  EXPECT_NEAR(hmax, 7.2, 1e-9);
}

namespace
{
// A detection whose flange and hole sit at (u, v) with the flange radius for `depth` m.
SpoolDetection detectionAt(double u, double v, double depth)
{
  SpoolDetection d;
  d.detected = d.hole_detected = true;
  d.flange.x = d.hole.x = u;
  d.flange.y = d.hole.y = v;
  d.flange.r = d.flange.r_vertical = 200 * 0.175 / depth;
  d.hole.r = 200 * 0.018 / depth;
  return d;
}
}  // namespace

TEST(SpoolGeometry, AlignedOnlyInTheWindowAndOnTheReference)
{
  GeometryParams p;
  p.overlap_tolerance = 2.0 / kThesis.fy;  // 2 px
  p.aligned_max_pixel_angle = 1.0;         // the thesis' 160x120 camera, as seed.yaml has it
  const SpoolGeometry g(p, kThesis);
  const double v55 = 59.5 + 200 * 0.06 / 0.55;

  SpoolDetection d = detectionAt(79.5, v55, 0.55);
  g.measure(d);
  EXPECT_NEAR(d.distance, 0.55, 1e-9);
  EXPECT_NEAR(d.range, std::hypot(0.55, 0.06), 1e-9);
  EXPECT_NEAR(d.axis_angle, 0.0, 1e-9);
  EXPECT_NEAR(d.yaw, 0.0, 1e-12);
  EXPECT_TRUE(d.overlapped);
  EXPECT_TRUE(d.aligned);

  d = detectionAt(79.5, 59.5 + 200 * 0.06 / 0.8, 0.8);  // overlapped but too far
  g.measure(d);
  EXPECT_TRUE(d.overlapped);
  EXPECT_FALSE(d.aligned);

  d = detectionAt(82.0, v55, 0.55);  // 2.5 px off: outside Rule 3
  g.measure(d);
  EXPECT_FALSE(d.overlapped);
  EXPECT_FALSE(d.aligned);
  EXPECT_NEAR(d.lateral_offset, 0.55 * 2.5 / 200.0, 1e-9);  // Eq. 3.8 at the depth

  d = detectionAt(79.5, v55, 0.55);
  d.hole_detected = false;  // no hole, no overlap
  g.measure(d);
  EXPECT_FALSE(d.overlapped);
}

TEST(SpoolGeometry, ASpoolAxisFarFromThePullerLevelIsNoSpoolToPick)
{
  const SpoolGeometry g(GeometryParams(), kThesis);
  // 0.8 m deep: the flange is 200 * 0.175 / 0.8 = 43.75 px in radius; the puller axis, 6 cm
  // below the camera, shows 15 px below the principal point.
  spool_vision::Circle flange;
  flange.x = 79.5;
  flange.r = flange.r_vertical = 200 * 0.175 / 0.8;
  EXPECT_NEAR(g.axisHeightOffset(flange, 59.5 + 15.0), 0.0, 1e-12);
  EXPECT_NEAR(g.axisHeightOffset(flange, 59.5), -0.06, 1e-12);
  EXPECT_TRUE(g.atPullerLevel(flange, 59.5 + 15.0 + 200 * 0.09 / 0.8));   // 9 cm below
  EXPECT_FALSE(g.atPullerLevel(flange, 59.5 + 15.0 - 200 * 0.11 / 0.8));  // 11 cm above
}

TEST(SpoolGeometry, PullerLevelRowsBoundEveryHoleAtThePullersLevel)
{
  const GeometryParams p;
  const SpoolGeometry g(p, kThesis);
  const auto [top, bottom] = g.pullerLevelRows();
  // Axis 4 cm above the camera (6 - 10 cm) is farthest up at the nearest depth; 16 cm below it at
  // the nearest depth too.
  EXPECT_NEAR(top, 59.5 + 200 * (0.06 - 0.1) / p.distance_min, 1e-9);
  EXPECT_NEAR(bottom, 59.5 + 200 * (0.06 + 0.1) / p.distance_min, 1e-9);
  // Over the working range, a hole at the puller's level lies between them; just outside, none.
  for (const double depth : {p.distance_min, 0.5 * (p.distance_min + p.distance_max), p.distance_max})
  {
    spool_vision::Circle flange;
    flange.x = 79.5;
    flange.r = flange.r_vertical = 200 * 0.175 / depth;
    for (int row = -100; row <= 340; ++row)  // v from -50 to 170 px in half pixels
    {
      const double v = 0.5 * row;
      if (g.atPullerLevel(flange, v))
      {
        EXPECT_GE(v, top - 1e-6) << depth;
        EXPECT_LE(v, bottom + 1e-6) << depth;
      }
    }
  }
  // The bounds themselves are reached: at the nearest depth, just inside each.
  spool_vision::Circle nearest;
  nearest.r = nearest.r_vertical = 200 * 0.175 / p.distance_min;
  EXPECT_TRUE(g.atPullerLevel(nearest, top + 0.01));
  EXPECT_TRUE(g.atPullerLevel(nearest, bottom - 0.01));
}

TEST(SpoolGeometry, YawBeyondTheLimitIsNotAligned)
{
  GeometryParams p;
  p.overlap_tolerance = 2.0 / kThesis.fy;  // 2 px
  p.aligned_max_yaw = 0.1 * kDeg;          // tighter than the 1.5 px overlap offset below (0.43 deg)
  const SpoolGeometry g(p, kThesis);
  SpoolDetection d = detectionAt(81.0, 59.5 + 200 * 0.06 / 0.55, 0.55);
  g.measure(d);
  EXPECT_TRUE(d.overlapped);
  EXPECT_FALSE(d.aligned);
}

TEST(SpoolGeometry, UndetectedLeavesNumbersUndefined)
{
  SpoolDetection d;
  SpoolGeometry(GeometryParams(), kThesis).measure(d);
  EXPECT_TRUE(std::isnan(d.distance));
  EXPECT_TRUE(std::isnan(d.yaw));
  EXPECT_TRUE(std::isnan(d.lateral_offset));
  EXPECT_NEAR(d.tolerance, 0.0025, 1e-12);
  EXPECT_FALSE(d.overlapped || d.aligned);
}

namespace
{
// The rim of a circle of radius r about c (m, camera frame) with normal n, imaged by `camera`
// and measured the way the detector does: the centre of an ellipse fitted to it and half its
// vertical extent. Independent of SpoolGeometry's conic.
spool_vision::Circle imagedRim(const CameraIntrinsics& camera, const cv::Vec3d& c, cv::Vec3d n, double r)
{
  n = cv::normalize(n);
  const cv::Vec3d a = cv::normalize(cv::Vec3d(0, 1, 0).cross(n));
  const cv::Vec3d b = n.cross(a);
  std::vector<cv::Point2f> rim;
  double top = 1e9;
  double bottom = -1e9;
  for (int i = 0; i < 3600; ++i)
  {
    const double phi = 2.0 * M_PI * i / 3600;
    const cv::Vec3d p = c + r * (std::cos(phi) * a + std::sin(phi) * b);
    const double v = camera.cy + camera.fy * p[1] / p[2];
    rim.emplace_back(static_cast<float>(camera.cx + camera.fx * p[0] / p[2]), static_cast<float>(v));
    top = std::min(top, v);
    bottom = std::max(bottom, v);
  }
  const cv::RotatedRect e = cv::fitEllipse(rim);
  spool_vision::Circle circle;
  circle.x = e.center.x;
  circle.y = e.center.y;
  circle.r = circle.r_vertical = 0.5 * (bottom - top);
  return circle;
}

// A spool's face centre (m, camera optical frame) and its axis turned (about y) and tilted (about x).
struct PoseCase
{
  cv::Vec3d centre;
  double yaw_deg, pitch_deg;
  // The axis, not normalised: (tan yaw, tan pitch, 1).
  cv::Vec3d axis() const
  {
    return {std::tan(yaw_deg * kDeg), std::tan(pitch_deg * kDeg), 1.0};
  }
};

std::ostream& operator<<(std::ostream& out, const PoseCase& k)
{
  return out << "centre " << k.centre << " yaw " << k.yaw_deg << " pitch " << k.pitch_deg;
}

// The bore's 3.6 cm front rim at pose `k` projected point by point (the exact pinhole image), and
// the corners of its bounding box.
struct ProjectedBoreRim
{
  ProjectedBoreRim(const CameraIntrinsics& camera, const PoseCase& k)
  {
    const cv::Vec3d axis = cv::normalize(k.axis());
    const cv::Vec3d u = cv::normalize(axis.cross(cv::Vec3d(0.0, 1.0, 0.0)));
    const cv::Vec3d v = axis.cross(u);
    constexpr int kPoints = 3600;
    for (int i = 0; i < kPoints; ++i)
    {
      const double t = 2.0 * M_PI * i / kPoints;
      const cv::Vec3d p = k.centre + 0.018 * (std::cos(t) * u + std::sin(t) * v);
      points.emplace_back(camera.cx + camera.fx * p[0] / p[2], camera.cy + camera.fy * p[1] / p[2]);
      low = {std::min(low.x, points.back().x), std::min(low.y, points.back().y)};
      high = {std::max(high.x, points.back().x), std::max(high.y, points.back().y)};
    }
  }
  std::vector<cv::Point2d> points;
  cv::Point2d low{1e9, 1e9};
  cv::Point2d high{-1e9, -1e9};
};

// Seen square on and 25-40 deg off its axis, turned or tilted.
const PoseCase kBorePoses[] = {PoseCase{{0.0, 0.06, 0.55}, 0.0, 0.0}, PoseCase{{-0.12, 0.07, 0.57}, -40.0, 0.0},
                               PoseCase{{0.2, 0.05, 0.8}, 30.0, 2.0}, PoseCase{{0.05, -0.1, 0.5}, 25.0, -25.0}};
}  // namespace

TEST(SpoolGeometry, RimPoseGivesDepthPositionAndAxisOfATiltedSpool)
{
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  for (const PoseCase& k : {PoseCase{{0.0, 0.06, 0.55}, 0.0, 0.0}, PoseCase{{0.2, 0.06, 0.55}, 0.0, 0.0},
                            PoseCase{{0.0, 0.06, 0.55}, 1.0, 0.0}, PoseCase{{0.15, 0.05, 0.6}, -4.0, 1.5},
                            PoseCase{{-0.35, 0.0, 1.05}, 5.0, -2.0}})
  {
    SCOPED_TRACE(::testing::Message() << k);
    const cv::Vec3d n = k.axis();
    SpoolDetection d;
    d.detected = d.hole_detected = true;
    d.flange = imagedRim(camera, k.centre, n, 0.175);
    d.hole.x = camera.cx + camera.fx * k.centre[0] / k.centre[2];
    d.hole.y = camera.cy + camera.fy * k.centre[1] / k.centre[2];
    d.hole.r = camera.fy * 0.018 / k.centre[2];
    g.measure(d);
    EXPECT_NEAR(d.distance, k.centre[2], 1e-4 * k.centre[2]);
    EXPECT_NEAR(d.position.x, k.centre[0], 1e-4);
    EXPECT_NEAR(d.position.y, k.centre[1], 1e-4);
    EXPECT_NEAR(d.range, cv::norm(k.centre), 1e-4);
    const cv::Vec3d truth = cv::normalize(n);
    EXPECT_NEAR(d.axis_angle, std::acos(truth[2]), 0.01 * kDeg);
    EXPECT_NEAR(d.axis_yaw, std::atan2(truth[0], truth[2]), 0.01 * kDeg);
    EXPECT_NEAR(d.lateral_offset, k.centre[0], 1e-4);
  }
}

// The bore's front rim projected point by point (the exact pinhole image of the 3.6 cm circle)
// spans what boreExtent() gives, seen square on and 25-40 deg off its axis, turned or tilted.
TEST(SpoolGeometry, BoreExtentIsTheProjectedFrontRimsHalfWidthAndHalfHeight)
{
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  for (const PoseCase& k : kBorePoses)
  {
    SCOPED_TRACE(::testing::Message() << k);
    const ProjectedBoreRim rim(camera, k);
    const cv::Size2d extent = g.boreExtent(cv::Point3d(k.centre), cv::normalize(k.axis()));
    EXPECT_NEAR(extent.width, 0.5 * (rim.high.x - rim.low.x), 0.02);
    EXPECT_NEAR(extent.height, 0.5 * (rim.high.y - rim.low.y), 0.02);
  }
  EXPECT_EQ(g.boreExtent({0.0, 0.0, -0.5}, {0.0, 0.0, 1.0}), cv::Size2d());
  EXPECT_EQ(g.boreExtent({0.0, 0.0, 0.5}, {std::nan(""), 0.0, 1.0}), cv::Size2d());
}

// The bore's front rim projected point by point lies on boreEllipse()'s ellipse about the
// projection's middle, to a tenth of a pixel, seen square on and 25-40 deg off its axis, turned or
// tilted; and it is the renderer's ellipse, tilted where the bore is below its axis's vanishing point.
TEST(SpoolGeometry, BoreEllipseIsTheProjectedFrontRimTiltedOffItsVanishingPointsRow)
{
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  for (const PoseCase& k : kBorePoses)
  {
    SCOPED_TRACE(::testing::Message() << k);
    const ProjectedBoreRim rim(camera, k);
    const cv::Point2d middle = 0.5 * (rim.low + rim.high);
    const spool_vision::EllipseShape e = g.boreEllipse(cv::Point3d(k.centre), cv::normalize(k.axis()));
    ASSERT_GT(e.semi_x, 0.0);
    const double c = std::cos(e.tilt);
    const double s = std::sin(e.tilt);
    for (const cv::Point2d& p : rim.points)
    {
      const cv::Point2d d = p - middle;
      const double rho = std::hypot((c * d.x + s * d.y) / e.semi_x, (c * d.y - s * d.x) / e.semi_y);
      ASSERT_NEAR((rho - 1.0) * std::min(e.semi_x, e.semi_y), 0.0, 0.1) << p;
    }
  }
  // The renderer's own ellipse of oblique seed 131 #8's bore at 640x480 (its exact pose, its camera):
  // semi-axes 24.96 x 28.89 px, the long one 79.3 deg from x (10.7 deg from upright).
  CameraIntrinsics rendered = camera;
  rendered.cx = 329.1;
  rendered.cy = 233.74;
  const SpoolGeometry at(GeometryParams(), rendered);
  const spool_vision::EllipseShape e =
      at.boreEllipse({0.04522, 0.06064, 0.50089}, cv::normalize(cv::Vec3d(-0.41343, -0.00618, 0.91052)));
  EXPECT_NEAR(e.semi_x, 24.96, 0.1);
  EXPECT_NEAR(e.semi_y, 28.89, 0.1);
  EXPECT_NEAR(e.tilt, -1.3838 + 0.5 * M_PI, 0.3 * kDeg);
  EXPECT_EQ(g.boreEllipse({0.0, 0.0, -0.5}, {0.0, 0.0, 1.0}).semi_x, 0.0);
}

TEST(SpoolGeometry, AnAxisThatWouldTakeThePullerIntoTheBoreWallIsNotAligned)
{
  // Centred on the puller at 55 cm: a 0.5 deg tilt moves the bore's back end 1.7 mm (inside
  // t_f = 2.5 mm), a 1 deg tilt 3.5 mm (into the wall).
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  const cv::Vec3d centre(0.0, 0.06, 0.55);
  for (const double deg : {0.5, 1.0})
  {
    SpoolDetection d;
    d.detected = d.hole_detected = true;
    d.flange = imagedRim(camera, centre, {std::tan(deg * kDeg), 0.0, 1.0}, 0.175);
    d.hole.x = camera.cx;
    d.hole.y = camera.cy + camera.fy * 0.06 / 0.55;
    g.measure(d);
    EXPECT_TRUE(d.overlapped);
    EXPECT_EQ(d.aligned, deg < 0.7) << deg << " deg";
  }
}

TEST(SpoolGeometry, AlignedAllowsForTheLongestBore)
{
  // 0.65 deg of tilt moves the axis 2.27 mm over a 20 cm bore (clear of t_f = 2.5 mm less the
  // 0.1 mm margin) but 2.50 mm over a 22 cm one: the same frame is aligned only for spools whose
  // bore is known to be at most 20 cm long.
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const cv::Vec3d centre(0.0, 0.06, 0.55);
  SpoolDetection d;
  d.detected = d.hole_detected = true;
  d.flange = imagedRim(camera, centre, {std::tan(0.65 * kDeg), 0.0, 1.0}, 0.175);
  d.hole.x = camera.cx;
  d.hole.y = camera.cy + camera.fy * 0.06 / 0.55;
  GeometryParams p;
  for (const double longest : {0.22, 0.2})
  {
    p.bore_length_max = longest;
    SpoolDetection measured = d;
    SpoolGeometry(p, camera).measure(measured);
    EXPECT_EQ(measured.aligned, longest < 0.21) << longest << " m";
  }
}

TEST(SpoolGeometry, AlignedOnlyWhereThePixelsResolveTheAxis)
{
  // The same centred spool at 55 cm: aligned through a 640x480 C270 (1.25 mrad per pixel), not
  // through its 320x240 or 160x120 modes (2.5 and 5 mrad), whose axis is too coarse to trust.
  const cv::Vec3d centre(0.0, 0.06, 0.55);
  for (const int width : {640, 320, 160})
  {
    const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(width, width * 3 / 4);
    SpoolDetection d;
    d.detected = d.hole_detected = true;
    d.flange = imagedRim(camera, centre, {0.0, 0.0, 1.0}, 0.175);
    d.hole.x = camera.cx;
    d.hole.y = camera.cy + camera.fy * 0.06 / 0.55;
    SpoolGeometry(GeometryParams(), camera).measure(d);
    EXPECT_TRUE(d.overlapped) << width;
    EXPECT_EQ(d.aligned, width == 640) << width;
  }
}

TEST(SpoolGeometry, WithoutAHoleThePositionIsTheFlangesAndTheAxisUnknown)
{
  SpoolDetection d = detectionAt(99.5, 59.5, 0.8);
  d.hole_detected = false;
  SpoolGeometry(GeometryParams(), kThesis).measure(d);
  EXPECT_NEAR(d.distance, 0.8, 1e-9);
  EXPECT_NEAR(d.position.x, 0.08, 1e-9);
  EXPECT_TRUE(std::isnan(d.axis_angle));
  EXPECT_FALSE(d.aligned);
}

namespace
{
// `count` points of the flange rim (35 cm) centred at `c` (m, camera frame) facing along `n`
// (unit), projected by `camera` (px, pinhole), in order around it.
std::vector<cv::Point2d> projectedRim(const CameraIntrinsics& camera, const cv::Vec3d& c, const cv::Vec3d& n, int count)
{
  const cv::Vec3d a = cv::normalize(cv::Vec3d(0, 1, 0).cross(n));
  const cv::Vec3d b = n.cross(a);
  std::vector<cv::Point2d> rim;
  for (int i = 0; i < count; ++i)
  {
    const double phi = 2.0 * M_PI * i / count;
    const cv::Vec3d p = c + 0.175 * (std::cos(phi) * a + std::sin(phi) * b);
    rim.emplace_back(camera.cx + camera.fx * p[0] / p[2], camera.cy + camera.fy * p[1] / p[2]);
  }
  return rim;
}
}  // namespace

TEST(SpoolGeometry, FitRimPoseUsesWhateverArcShows)
{
  // 40% of a rim (the rest beyond the frame's right border), 0.2 px noise, outliers of a back
  // flange's crescent 8 px inside: depth and axis from the arc alone, started off the truth.
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  const cv::Vec3d c(0.22, 0.06, 0.6);
  const cv::Vec3d n = cv::normalize(cv::Vec3d(std::tan(-3.0 * kDeg), std::tan(1.0 * kDeg), 1.0));
  const cv::Point2d centre(camera.cx + camera.fx * c[0] / c[2], camera.cy + camera.fy * c[1] / c[2]);
  cv::RNG rng(7);
  std::vector<cv::Point2f> rim;
  const std::vector<cv::Point2d> projected = projectedRim(camera, c, n, 2000);
  for (std::size_t i = 0; i < projected.size(); ++i)
  {
    const cv::Point2d q = projected[i];
    if (q.x > 500.0)
      continue;
    const double inward = i % 10 == 0 ? 8.0 : 0.0;  // every tenth point: the crescent
    const cv::Point2d out = (q - centre) / cv::norm(q - centre);
    rim.emplace_back(static_cast<float>(q.x - inward * out.x + rng.gaussian(0.2)),
                     static_cast<float>(q.y - inward * out.y + rng.gaussian(0.2)));
  }
  ASSERT_GT(rim.size(), 400u);
  cv::Point3d position(0.0, 0.0, 0.606);  // 1% deep, facing the camera
  cv::Vec3d axis(0.0, 0.0, 1.0);
  ASSERT_TRUE(g.fitRimPose(rim, centre, position, axis));
  EXPECT_NEAR(position.z, c[2], 0.001 * c[2]);
  EXPECT_NEAR(position.x, c[0], 0.001);
  EXPECT_NEAR(std::acos(axis.dot(n)) / kDeg, 0.0, 0.2);

  // Too few points: refused, outputs untouched.
  const std::vector<cv::Point2f> few(rim.begin(), rim.begin() + 20);
  cv::Point3d untouched(1, 2, 3);
  EXPECT_FALSE(g.fitRimPose(few, centre, untouched, axis));
  EXPECT_EQ(untouched, cv::Point3d(1, 2, 3));
}

// A rim seen 35 deg off its axis, turned either way, whose measured ellipse is 3% tall and gave no
// plausible pose (axis NaN, depth from Eq. 3.2 3% short): fitted on the rim from the two axes the
// ellipse's aspect allows, the pose is the rim's, whichever way it is turned.
TEST(SpoolGeometry, APoseTheEllipseCouldNotGiveIsFittedOnTheRimFromItsAspect)
{
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  const cv::Vec3d c(0.03, 0.06, 0.7);
  for (const double turn : {35.0, -35.0})
  {
    SCOPED_TRACE(::testing::Message() << "turned " << turn << " deg");
    const double yaw = std::atan2(c[0], c[2]) + turn * kDeg;
    const cv::Vec3d n(std::sin(yaw), 0.0, std::cos(yaw));
    std::vector<cv::Point2f> rim;
    for (const cv::Point2d& q : projectedRim(camera, c, n, 1000))
      rim.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
    SpoolDetection d;
    d.detected = d.hole_detected = true;
    d.flange = imagedRim(camera, c, n, 0.175);
    const cv::RotatedRect box = cv::fitEllipse(rim);
    d.flange.r_vertical *= 1.03;
    d.flange.r_horizontal = 0.5 * 1.03 * std::min(box.size.width, box.size.height);
    d.hole.x = camera.cx + camera.fx * c[0] / c[2];
    d.hole.y = camera.cy + camera.fy * c[1] / c[2];
    d.position = g.backProject(d.hole.x, d.hole.y, g.depthFromDiameter(2.0 * d.flange.r_vertical));
    d.axis = cv::Vec3d(SpoolDetection::kNaN, SpoolDetection::kNaN, SpoolDetection::kNaN);
    ASSERT_TRUE(g.measureFromAspect(d, rim));
    EXPECT_NEAR(d.distance, c[2], 0.002 * c[2]);
    EXPECT_NEAR(std::acos(std::clamp(d.axis.dot(n), -1.0, 1.0)) / kDeg, 0.0, 0.3);
    EXPECT_NEAR(d.axis_angle, std::acos(n[2]), 0.3 * kDeg);
    // Already posed, or without the rim: nothing to do.
    const SpoolDetection posed = d;
    EXPECT_FALSE(g.measureFromAspect(d, rim));
    EXPECT_EQ(d.distance, posed.distance);
    d.axis = cv::Vec3d(SpoolDetection::kNaN, SpoolDetection::kNaN, SpoolDetection::kNaN);
    EXPECT_FALSE(g.measureFromAspect(d, {}));
  }
}

TEST(SpoolGeometry, FitRimPoseFitsTheCentreTooWithinItsReach)
{
  // A rim seen 35 deg off its axis at 70 cm, its bore measured 5 px off the true centre (a dark
  // bore seen that far off shows part of its opening dark): within a reach of 8 px the centre is
  // fitted with depth and axis; with 2 px it is refused, outputs untouched.
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  const cv::Vec3d c(0.05, 0.06, 0.7);
  const cv::Vec3d n(std::sin(35.0 * kDeg), 0.0, std::cos(35.0 * kDeg));
  cv::RNG rng(11);
  std::vector<cv::Point2f> rim;
  for (const cv::Point2d& q : projectedRim(camera, c, n, 600))
    rim.emplace_back(static_cast<float>(q.x + rng.gaussian(0.2)), static_cast<float>(q.y + rng.gaussian(0.2)));
  const cv::Point2d truth(camera.cx + camera.fx * c[0] / c[2], camera.cy + camera.fy * c[1] / c[2]);
  const cv::Point2d bore = truth + cv::Point2d(-5.0, 0.0);
  const cv::Point3d start(0.0, 0.0, 0.72);
  const cv::Vec3d start_axis = cv::normalize(cv::Vec3d(std::tan(30.0 * kDeg), 0.0, 1.0));

  cv::Point3d position = start;
  cv::Vec3d axis = start_axis;
  int support = 0;
  ASSERT_TRUE(g.fitRimPose(rim, bore, position, axis, &support, 8.0));
  EXPECT_NEAR(position.z, c[2], 0.002 * c[2]);
  EXPECT_NEAR(position.x, c[0], 0.001);
  EXPECT_NEAR(position.y, c[1], 0.001);
  EXPECT_NEAR(std::acos(axis.dot(n)) / kDeg, 0.0, 0.3);
  EXPECT_GT(support, 500);

  // About the bore's own ray the circle misses part of the rim (from the frame's 96 moving edges,
  // fewer than the fit's 30 points were left).
  cv::Point3d about_ray = start;
  cv::Vec3d about_ray_axis = start_axis;
  int about_ray_support = 0;
  if (g.fitRimPose(rim, bore, about_ray, about_ray_axis, &about_ray_support))
  {
    EXPECT_LT(about_ray_support, 0.7 * support);
  }

  cv::Point3d untouched = start;
  EXPECT_FALSE(g.fitRimPose(rim, bore, untouched, axis, nullptr, 2.0));
  EXPECT_EQ(untouched, start);
}

TEST(SpoolGeometry, ACutRimsSquashedEllipseDoesNotTrapTheRimFit)
{
  // 320x240 at 54 cm: the rim overfills the frame and is cut at the bottom; the ellipse fitted to
  // what shows came out 6% short vertically (spool_sim seed 8), which put rimPose() 6% deep and
  // the true rim outside the rim fit's band. The circle's own size starts a second fit.
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(320, 240);
  const SpoolGeometry g(GeometryParams(), camera);
  const cv::Vec3d c(0.0, 0.0575, 0.542);
  cv::RNG rng(3);
  std::vector<cv::Point2f> rim;
  for (int i = 0; i < 2000; ++i)
  {
    const double phi = 2.0 * M_PI * i / 2000;
    const double u = camera.cx + camera.fx * (c[0] + 0.175 * std::cos(phi)) / c[2];
    const double v = camera.cy + camera.fy * (c[1] + 0.175 * std::sin(phi)) / c[2];
    if (v < camera.height - 1.0)
      rim.emplace_back(static_cast<float>(u + rng.gaussian(0.2)), static_cast<float>(v + rng.gaussian(0.2)));
  }
  SpoolDetection d;
  d.detected = d.hole_detected = true;
  d.hole.x = d.flange.x = camera.cx + camera.fx * c[0] / c[2];
  d.hole.y = d.flange.y = camera.cy + camera.fy * c[1] / c[2];
  d.hole.r = camera.fy * 0.018 / c[2];
  d.flange.r = d.flange.r_horizontal = camera.fy * 0.175 / c[2];
  d.flange.r_vertical = 0.94 * d.flange.r;
  g.measure(d, rim);
  EXPECT_NEAR(d.distance, c[2], 0.005 * c[2]);
  EXPECT_NEAR(d.axis_angle, 0.0, 0.5 * kDeg);
}

TEST(SpoolGeometry, NoPoseOutsidePhysicsWhateverTheRimPoints)
{
  // Arbitrary measurements (flange ellipse, hole, edge points on other circles, lines, noise):
  // whatever the fits do, a published pose has its depth within 15% of Eq. 3.2 on the flange's
  // vertical semi-axis and its axis within 40 deg of the line of sight, or no axis at all.
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const SpoolGeometry g(GeometryParams(), camera);
  cv::RNG rng(11);
  int without_axis = 0;
  for (int i = 0; i < 3000; ++i)
  {
    SpoolDetection d;
    d.detected = d.hole_detected = true;
    d.flange.x = rng.uniform(-100.0, 740.0);
    d.flange.y = rng.uniform(-100.0, 580.0);
    d.flange.r = rng.uniform(60.0, 500.0);
    d.flange.r_vertical = d.flange.r * rng.uniform(0.8, 1.2);
    d.flange.r_horizontal = d.flange.r * rng.uniform(0.8, 1.2);
    d.hole.x = d.flange.x + rng.uniform(-0.2, 0.2) * d.flange.r;
    d.hole.y = d.flange.y + rng.uniform(-0.2, 0.2) * d.flange.r;
    d.hole.r = d.flange.r * rng.uniform(0.05, 0.2);
    std::vector<cv::Point2f> rim;
    const cv::Point2d c(d.flange.x + rng.uniform(-50.0, 50.0), d.flange.y + rng.uniform(-50.0, 50.0));
    const double a = d.flange.r * rng.uniform(0.5, 1.5);
    const double b = d.flange.r * rng.uniform(0.5, 1.5);
    const int points = rng.uniform(0, 800);
    for (int k = 0; k < points; ++k)
    {
      const double phi = rng.uniform(0.0, rng.uniform(0.5, 2.0 * M_PI));
      const bool noise = rng.uniform(0.0, 1.0) < 0.2;
      rim.emplace_back(static_cast<float>(noise ? rng.uniform(0.0, 640.0) : c.x + a * std::cos(phi)),
                       static_cast<float>(noise ? rng.uniform(0.0, 480.0) : c.y + b * std::sin(phi)));
    }
    g.measure(d, rim);
    const double eq32 = camera.fy * 0.35 / (2.0 * d.flange.r_vertical);
    ASSERT_TRUE(std::isfinite(d.distance) && d.distance > 0.0) << i;
    if (!std::isfinite(d.axis[2]))
    {
      ++without_axis;
      EXPECT_NEAR(d.distance, eq32, 1e-9 * eq32) << i;
      EXPECT_FALSE(d.aligned) << i;
      continue;
    }
    EXPECT_LE(std::abs(d.distance / eq32 - 1.0), 0.15) << i;
    const cv::Vec3d ray = cv::normalize(cv::Vec3d(d.position.x, d.position.y, d.position.z));
    EXPECT_LE(std::acos(std::min(1.0, std::abs(ray.dot(d.axis)))), 40.0 * kDeg + 1e-9) << i;
  }
  // The check is exercised: some of these fits went where no rim could have been seen.
  EXPECT_GT(without_axis, 0);
}
