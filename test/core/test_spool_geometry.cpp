#include <gtest/gtest.h>

#include <cmath>

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

TEST(SpoolGeometry, RangeFollowsTheViewingRay)
{
  const SpoolGeometry g(GeometryParams(), kThesis);
  // Centred: range == depth. 40 px right at f = 200: ray factor sqrt(1 + 0.2^2).
  EXPECT_NEAR(g.distance(79.5, 59.5, 35.0), 1.0, 1e-12);
  EXPECT_NEAR(g.distance(119.5, 59.5, 35.0), std::sqrt(1.04), 1e-12);
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
  const SpoolGeometry g(p, kThesis);
  const double v55 = 59.5 + 200 * 0.06 / 0.55;

  SpoolDetection d = detectionAt(79.5, v55, 0.55);
  g.measure(d);
  EXPECT_NEAR(d.distance, 0.55 * std::hypot(1.0, 0.06 / 0.55), 1e-9);
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
  EXPECT_NEAR(d.lateral_offset, d.distance * std::tan(std::atan(2.5 / 200.0)), 1e-12);

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
