// The ROS-free overlay: colours where the thesis puts them, and the input is never written.
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "spool_vision/overlay.h"

namespace spool_vision
{
namespace
{
SpoolDetection detection()
{
  SpoolDetection d;
  d.detected = d.hole_detected = d.overlapped = d.aligned = true;
  d.distance = 0.55;
  d.yaw = 0.0;
  d.flange = Circle{320.0, 300.0, 150.0};
  d.hole = Circle{320.0, 300.0, 20.0};
  d.reference = cv::Point2d(320.0, 300.0);
  return d;
}

bool hasColour(const cv::Mat& bgr, cv::Point at, const cv::Vec3b& colour)
{
  // Anti-aliased lines: look for a saturated pixel near the expected spot.
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx)
    {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(at + cv::Point(dx, dy));
      if (cv::norm(cv::Vec3d(p) - cv::Vec3d(colour)) < 60.0)
        return true;
    }
  return false;
}

TEST(Overlay, DrawsFlangeHoleAndReferenceInTheThesisColours)
{
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  const cv::Mat out = renderOverlay(grey, PixelFormat::kMono8, detection());
  ASSERT_EQ(out.type(), CV_8UC3);
  EXPECT_TRUE(hasColour(out, {320, 150}, {0, 0, 255}));  // flange rim, red
  EXPECT_TRUE(hasColour(out, {470, 300}, {0, 0, 255}));
  EXPECT_TRUE(hasColour(out, {320, 280}, {255, 0, 0}));   // hole rim, blue
  EXPECT_TRUE(hasColour(out, {326, 300}, {0, 255, 0}));   // reference cross arm, green
  EXPECT_FALSE(hasColour(out, {100, 400}, {0, 0, 255}));  // nothing drawn elsewhere
}

TEST(Overlay, DrawsAnObliqueFlangeAsTheEllipseMeasured)
{
  // A flange seen 30 deg off its axis: 130 px wide, 150 px high about (320, 300).
  SpoolDetection d = detection();
  d.flange.r_vertical = 150.0;
  d.flange.r_horizontal = 130.0;
  d.flange.r = 140.0;
  const cv::Mat out = renderOverlay(cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)), PixelFormat::kMono8, d);
  EXPECT_TRUE(hasColour(out, {320, 150}, {0, 0, 255}));   // top
  EXPECT_TRUE(hasColour(out, {450, 300}, {0, 0, 255}));   // side
  EXPECT_FALSE(hasColour(out, {460, 300}, {0, 0, 255}));  // not the mean circle's side
}

TEST(Overlay, NeverWritesItsInput)
{
  cv::Mat bgr(120, 160, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat before = bgr.clone();
  const cv::Mat out = renderOverlay(bgr, PixelFormat::kBgr8, detection());
  EXPECT_EQ(cv::norm(bgr, before, cv::NORM_INF), 0.0);
  EXPECT_NE(out.data, bgr.data);
}

TEST(Overlay, UndetectedFrameGetsOnlyTheReferenceAndAText)
{
  SpoolDetection d;
  d.reference = cv::Point2d(80.0, 50.0);
  const cv::Mat grey(120, 160, CV_8UC1, cv::Scalar(128));
  const cv::Mat out = renderOverlay(grey, PixelFormat::kMono8, d);
  cv::Mat red_mask;
  cv::inRange(out, cv::Scalar(0, 0, 200), cv::Scalar(60, 60, 255), red_mask);
  EXPECT_EQ(cv::countNonZero(red_mask), 0);
  EXPECT_TRUE(hasColour(out, {83, 50}, {0, 255, 0}));
}

TEST(Overlay, RejectsMismatchedInput)
{
  EXPECT_THROW(renderOverlay(cv::Mat(), PixelFormat::kMono8, detection()), std::invalid_argument);
  EXPECT_THROW(renderOverlay(cv::Mat(10, 10, CV_8UC3), PixelFormat::kMono8, detection()), std::invalid_argument);
}

}  // namespace

TEST(Overlay, Mono16IsScaledAsTheDetectorScalesIt)
{
  // One conversion path: 257 * v (the full 16-bit range) shows as v, as the detector sees it.
  const cv::Mat mono16(60, 80, CV_16UC1, cv::Scalar(257 * 100));
  const cv::Mat out = renderOverlay(mono16, PixelFormat::kMono16, SpoolDetection());
  EXPECT_EQ(out.at<cv::Vec3b>(2, 2), cv::Vec3b(100, 100, 100));
}

}  // namespace spool_vision
