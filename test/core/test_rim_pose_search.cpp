#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "spool_vision/rim_pose_search.h"

using spool_vision::CameraIntrinsics;
using spool_vision::GeometryParams;
using spool_vision::PixelFormat;
using spool_vision::Polarity;
using spool_vision::RimPoseFit;
using spool_vision::RimPoseSearch;
using spool_vision::RimSearch;
using spool_vision::SpoolGeometry;

namespace
{
const CameraIntrinsics kVga = CameraIntrinsics::thesisDefault(640, 480);
constexpr double kDeg = M_PI / 180.0;
constexpr double kFlangeRadius = 0.175;  // m
constexpr double kHubLength = 0.2;       // m, front face to back flange

// A circle of `radius` m about `centre` in the plane normal to `axis`, through kVga's pinhole,
// in 1/16 px (cv::fillPoly's shift 4).
std::vector<cv::Point> projectedCircle(const cv::Vec3d& centre, const cv::Vec3d& axis, double radius)
{
  const cv::Vec3d u = cv::normalize(axis.cross(cv::Vec3d(0.0, 1.0, 0.0)));
  const cv::Vec3d v = axis.cross(u);
  std::vector<cv::Point> points;
  for (int k = 0; k < 720; ++k)
  {
    const double t = 2.0 * M_PI * k / 720.0;
    const cv::Vec3d p = centre + radius * (std::cos(t) * u + std::sin(t) * v);
    points.emplace_back(cvRound(16.0 * (kVga.fx * p[0] / p[2] + kVga.cx)),
                        cvRound(16.0 * (kVga.fy * p[1] / p[2] + kVga.cy)));
  }
  return points;
}

void fill(cv::Mat& image, const std::vector<cv::Point>& polygon, int level)
{
  cv::fillPoly(image, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar::all(level), cv::LINE_AA, 4);
}

// A spool seen obliquely on a light wall: the back flange (dark) behind the front one (grey),
// optionally a raised rib ring on the face at `rib` of the flange's radius, and the dark bore.
cv::Mat obliqueSpool(const cv::Vec3d& front, const cv::Vec3d& axis, double rib = 0.0)
{
  cv::Mat image(kVga.height, kVga.width, CV_8UC3, cv::Scalar::all(200));
  fill(image, projectedCircle(front + kHubLength * axis, axis, kFlangeRadius), 40);
  fill(image, projectedCircle(front, axis, kFlangeRadius), 90);
  if (rib > 0.0)
    cv::polylines(image, std::vector<std::vector<cv::Point>>{projectedCircle(front, axis, rib * kFlangeRadius)}, true,
                  cv::Scalar::all(30), 3, cv::LINE_AA, 4);
  fill(image, projectedCircle(front, axis, 0.018), 10);
  return image;
}

cv::Point2d bore(const cv::Vec3d& front)
{
  return {kVga.fx * front[0] / front[2] + kVga.cx, kVga.fy * front[1] / front[2] + kVga.cy};
}

RimSearch search()
{
  RimSearch s;
  s.reach = 9.0;
  s.polarity = Polarity::kAny;
  s.threshold = 0.05;
  return s;
}

// The spool axis turned `yaw` from the line of sight to `front`, level.
cv::Vec3d turned(const cv::Vec3d& front, double yaw)
{
  const double sight = std::atan2(front[0], front[2]);
  return {std::sin(sight + yaw), 0.0, std::cos(sight + yaw)};
}

// obliqueSpool() with its face centre at `front` (m) and its axis turned `yaw` from the line of sight.
struct TurnedSpool
{
  cv::Vec3d front;
  cv::Vec3d axis;
  cv::Mat image;
};

TurnedSpool turnedSpool(const cv::Vec3d& front, double yaw)
{
  const cv::Vec3d axis = turned(front, yaw);
  return {front, axis, obliqueSpool(front, axis)};
}

// kVga's geometry and a RimPoseSearch on its camera.
struct Searcher
{
  SpoolGeometry geometry{GeometryParams{}, kVga};
  RimPoseSearch rims;
  Searcher()
  {
    rims.setCamera(kVga);
  }
};
}  // namespace

TEST(RimPoseSearch, FindsAFlangeSeen35DegreesOffItsAxisBesideItsBackFlange)
{
  Searcher searcher;
  for (const double yaw : {-35.0 * kDeg, 35.0 * kDeg})
  {
    SCOPED_TRACE(yaw / kDeg);
    const TurnedSpool spool = turnedSpool({0.1, 0.04, 0.8}, yaw);
    RimPoseFit fit;
    // As a circle too large (the joint silhouette) would put it: 15% too near.
    ASSERT_TRUE(searcher.rims.search(spool.image, PixelFormat::kBgr8, searcher.geometry, bore(spool.front), 0.93 * 0.68,
                                     1.21 * 0.68, search(), fit));
    EXPECT_NEAR(fit.position.z, spool.front[2], 0.01 * spool.front[2]);
    EXPECT_NEAR(std::atan2(fit.axis[0], fit.axis[2]), std::atan2(spool.axis[0], spool.axis[2]), 2.0 * kDeg);
    EXPECT_GT(fit.support, 0.8);
  }
}

TEST(RimPoseSearch, TakesTheFlangeOutsideARibRingAboutTheSameBore)
{
  // The rib ring at 0.8 of the flange is a whole circle about the bore too, at 1.25 times the
  // depth as a flange; the range tried centres on it, and the rim outside it wins.
  const SpoolGeometry geometry(GeometryParams{}, kVga);
  RimPoseSearch rims;
  rims.setCamera(kVga);
  const cv::Vec3d front(-0.05, 0.04, 0.7);
  const cv::Vec3d axis = turned(front, 25.0 * kDeg);
  const cv::Mat image = obliqueSpool(front, axis, 0.8);
  RimPoseFit fit;
  ASSERT_TRUE(rims.search(image, PixelFormat::kBgr8, geometry, bore(front), 0.8, 1.0, search(), fit));
  EXPECT_NEAR(fit.position.z, front[2], 0.01 * front[2]);
}

TEST(RimPoseSearch, FindsNoRimAboutABoreOnABlankWall)
{
  const SpoolGeometry geometry(GeometryParams{}, kVga);
  RimPoseSearch rims;
  rims.setCamera(kVga);
  cv::Mat image(kVga.height, kVga.width, CV_8UC3, cv::Scalar::all(200));
  cv::circle(image, {320, 240}, 20, cv::Scalar::all(10), cv::FILLED);
  RimPoseFit fit;
  EXPECT_FALSE(rims.search(image, PixelFormat::kBgr8, geometry, {320.0, 240.0}, 0.6, 1.0, search(), fit));
  EXPECT_FALSE(std::isfinite(fit.position.z));
}

// A neighbour seen 55 deg off its axis: beyond what search() tries (kMaxViewAngle), found by
// searchAbout() about the axis of a spool beside it (turned 8 deg from its own).
TEST(RimPoseSearch, FindsARimSeen55DegreesOffItsAxisAboutAGivenAxis)
{
  Searcher searcher;
  for (const double yaw : {-55.0 * kDeg, 55.0 * kDeg})
  {
    SCOPED_TRACE(yaw / kDeg);
    const TurnedSpool spool = turnedSpool({0.02, 0.04, 0.9}, yaw);
    const double axis_yaw = std::atan2(spool.axis[0], spool.axis[2]);
    const cv::Point2d centre = bore(spool.front);
    RimPoseFit fit;
    ASSERT_TRUE(searcher.rims.searchAbout(spool.image, PixelFormat::kBgr8, searcher.geometry, centre, 0.75, 1.1,
                                          search(), axis_yaw + (yaw > 0.0 ? 8.0 : -8.0) * kDeg, 20.0 * kDeg, fit));
    EXPECT_NEAR(fit.position.z, spool.front[2], 0.02 * spool.front[2]);
    EXPECT_NEAR(std::atan2(fit.axis[0], fit.axis[2]), axis_yaw, 3.0 * kDeg);
    EXPECT_GT(fit.support, 0.6);
    // search() tries axes only up to 40 deg off the line of sight: none fits this rim as well.
    RimPoseFit near_axis;
    if (searcher.rims.search(spool.image, PixelFormat::kBgr8, searcher.geometry, centre, 0.75, 1.1, search(),
                             near_axis))
    {
      EXPECT_GT(std::abs(std::atan2(near_axis.axis[0], near_axis.axis[2]) - axis_yaw), 5.0 * kDeg);
    }
  }
}
