#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "spool_vision/camera_model.h"
#include "spool_vision/hough_accumulator.h"
#include "spool_vision/spool_detector.h"
#include "synthetic.h"

using spool_vision::CameraIntrinsics;
using spool_vision::distortPixel;
using spool_vision::PixelFormat;
using spool_vision::SpoolDetection;
using spool_vision::SpoolDetector;
namespace st = spool_vision::test;

namespace
{
// A Logitech C270 class lens at 640x480 (k1 about -0.2), principal point off centre.
CameraIntrinsics c270()
{
  CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  camera.cx = 326.0;
  camera.cy = 236.0;
  camera.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  return camera;
}

CameraIntrinsics withoutDistortion(CameraIntrinsics camera)
{
  camera.distortion.clear();
  return camera;
}

// The raw frame the lens makes of an ideal (undistorted) image: each raw pixel shows what its
// undistorted position shows (cv::undistortPoints, independent of the detector's maps).
cv::Mat distortImage(const cv::Mat& ideal, const CameraIntrinsics& camera)
{
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  std::vector<cv::Point2f> raw;
  for (int y = 0; y < ideal.rows; ++y)
    for (int x = 0; x < ideal.cols; ++x)
      raw.emplace_back(static_cast<float>(x), static_cast<float>(y));
  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(raw, undistorted, k, camera.distortion, cv::noArray(), k);
  cv::Mat map(ideal.size(), CV_32FC2, undistorted.data());
  cv::Mat out;
  cv::remap(ideal, out, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}
}  // namespace

TEST(CameraModel, DistortPixelIsOpenCvsLensModel)
{
  for (const std::vector<double>& d : {std::vector<double>{-0.2, 0.05, 0.001, -0.0005, 0.01},
                                       std::vector<double>{-0.3, 0.1, 0.0, 0.002, -0.02, 0.05, -0.01, 0.003},
                                       std::vector<double>{0.1, -0.02, 0.0, 0.0}})
  {
    CameraIntrinsics camera = c270();
    camera.distortion = d;
    const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    for (const cv::Point2d p : {cv::Point2d(10, 15), cv::Point2d(326, 236), cv::Point2d(600, 90), cv::Point2d(50, 470)})
    {
      const std::vector<cv::Point3d> ray = {{(p.x - camera.cx) / camera.fx, (p.y - camera.cy) / camera.fy, 1.0}};
      std::vector<cv::Point2d> expected;
      cv::projectPoints(ray, cv::Vec3d(), cv::Vec3d(), k, d, expected);
      const cv::Point2d got = distortPixel(camera, p);
      EXPECT_NEAR(got.x, expected[0].x, 1e-9);
      EXPECT_NEAR(got.y, expected[0].y, 1e-9);
    }
  }
  EXPECT_EQ(distortPixel(withoutDistortion(c270()), {12.5, 7.25}), cv::Point2d(12.5, 7.25));
}

TEST(CameraModel, UndistortPixelInvertsDistortPixel)
{
  // Across a C270-like lens's frame, corners included: the raw pixel a point maps to maps back
  // to it within 0.001 px; without distortion, the point itself.
  const CameraIntrinsics camera = c270();
  for (const cv::Point2d p :
       {cv::Point2d(0.0, 0.0), cv::Point2d(639.0, 479.0), cv::Point2d(320.5, 10.25), cv::Point2d(15.0, 400.0)})
  {
    const cv::Point2d back = undistortPixel(camera, distortPixel(camera, p));
    EXPECT_NEAR(back.x, p.x, 1e-3);
    EXPECT_NEAR(back.y, p.y, 1e-3);
  }
  EXPECT_EQ(undistortPixel(withoutDistortion(c270()), {12.5, 7.25}), cv::Point2d(12.5, 7.25));
}

TEST(CameraModel, ADistortedFrameMeasuresLikeItsUndistortedTwin)
{
  // A spool 25 cm right of the axis at 80 cm: k1 = -0.2 moves its centre by about 5 px.
  const CameraIntrinsics camera = c270();
  const CameraIntrinsics ideal_camera = withoutDistortion(camera);
  const st::DrawnSpool spool = st::spoolAt(ideal_camera, 0.8, 0.25, 0.06);
  const cv::Mat ideal = st::drawScene({640, 480}, {spool});
  const cv::Mat raw = distortImage(ideal, camera);

  SpoolDetector twin;
  twin.setCamera(ideal_camera);
  const SpoolDetection reference = twin.detect(ideal, PixelFormat::kBgr8);
  ASSERT_TRUE(reference.hole_detected);

  SpoolDetector detector;
  detector.setCamera(camera);
  const SpoolDetection d = detector.detect(raw, PixelFormat::kBgr8);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_NEAR(d.distance, reference.distance, 0.002 * reference.distance);
  EXPECT_NEAR(d.lateral_offset, reference.lateral_offset, 0.0005);
  EXPECT_NEAR(d.yaw, reference.yaw, 0.05 * M_PI / 180);
  // Centres are reported where the frame shows them.
  const cv::Point2d seen = distortPixel(camera, {spool.x, spool.y});
  EXPECT_NEAR(d.hole.x, seen.x, 0.5);
  EXPECT_NEAR(d.hole.y, seen.y, 0.5);

  // The same raw frame measured as if it had no distortion is off by far more.
  SpoolDetector naive;
  naive.setCamera(ideal_camera);
  const SpoolDetection wrong = naive.detect(raw, PixelFormat::kBgr8);
  ASSERT_TRUE(wrong.detected);
  EXPECT_GT(std::abs(wrong.yaw - reference.yaw), 0.2 * M_PI / 180);
  EXPECT_GT(std::abs(wrong.distance - reference.distance), 0.01 * reference.distance);
}

TEST(CameraModel, AWildCalibrationLeavesNoEdgeWithoutAPositionOrDirection)
{
  // Found by detector_fuzz: a rational_polynomial lens whose denominator nearly vanishes in the
  // frame's corners has no inverse there; its edges came out NaN and voted out of range. (Its
  // other find, edges 1e13 px off the frame, is the seed test/fuzz/corpus/detector_fuzz/
  // wild_lens_far_edges, replayed by every fuzz run.)
  CameraIntrinsics camera = CameraIntrinsics::thesisDefault(118, 47);
  camera.cx -= 0.1 * 118;
  camera.cy -= 0.2 * 47;
  camera.distortion = {-0.31, -0.5, -0.0196, -0.02, -0.5, -0.5, -0.5, -0.5};
  cv::Mat noise(47, 118, CV_8U);
  cv::randu(noise, 0, 256);
  spool_vision::EdgeDetector edges;
  edges.setUndistortion(camera);
  std::vector<spool_vision::EdgePoint> found;
  edges.detect(noise, 0.03, 100000, found);
  for (const spool_vision::EdgePoint& e : found)
    ASSERT_TRUE(std::abs(e.x) < 3 * 118 && std::abs(e.y) < 3 * 47 && std::isfinite(e.dx) && std::isfinite(e.dy));

  SpoolDetector detector;
  detector.setCamera(camera);
  cv::Mat bgr;
  cv::cvtColor(noise, bgr, cv::COLOR_GRAY2BGR);
  EXPECT_NO_THROW(detector.detect(bgr, PixelFormat::kBgr8));
}

TEST(CameraModel, TheUndistortionTableInvertsTheLensAtEveryPixel)
{
  // The table solves the lens model on a grid and interpolates in between: each pixel's entry,
  // put back through the lens (distortPixel, the model written out), lands on that pixel, for a
  // C270-like lens at 640x480 and 1280x720 and a strong rational_polynomial one.
  CameraIntrinsics hd = CameraIntrinsics::thesisDefault(1280, 720);
  hd.cx = 652.0;
  hd.cy = 350.0;
  hd.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  CameraIntrinsics rational = c270();
  rational.distortion = {-0.35, 0.12, 0.0005, 0.0003, -0.02, 0.05, 0.01, 0.002};
  for (const CameraIntrinsics& camera : {c270(), hd, rational})
  {
    cv::Mat table;
    spool_vision::undistortionTable(camera, table);
    ASSERT_EQ(table.size(), cv::Size(camera.width, camera.height));
    ASSERT_EQ(table.type(), CV_32FC2);
    double worst = 0.0;
    for (int y = 0; y < table.rows; ++y)
      for (int x = 0; x < table.cols; ++x)
      {
        const cv::Vec2f u = table.at<cv::Vec2f>(y, x);
        const cv::Point2d back = distortPixel(camera, {u[0], u[1]});
        worst = std::max(worst, std::hypot(back.x - x, back.y - y));
      }
    EXPECT_LT(worst, 0.002) << camera.width << "x" << camera.height << ", " << camera.distortion.size()
                            << " coefficients";
  }
}
