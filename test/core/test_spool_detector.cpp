#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>

#include <opencv2/imgproc.hpp>

#include "spool_vision/spool_detector.h"
#include "spool_vision/spool_tracker.h"
#include "synthetic.h"

using spool_vision::CameraIntrinsics;
using spool_vision::DetectorParams;
using spool_vision::MatchMode;
using spool_vision::PixelFormat;
using spool_vision::SpoolDetection;
using spool_vision::SpoolDetector;
using spool_vision::test::DrawnSpool;
using spool_vision::test::drawScene;
using spool_vision::test::spoolAt;

// Counts heap allocations while enabled, to check the steady-state promise.
namespace
{
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
}  // namespace
void* operator new(std::size_t n)
{
  if (g_counting)
    ++g_allocations;
  if (void* p = std::malloc(n ? n : 1))
    return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept
{
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept
{
  std::free(p);
}

namespace
{
const CameraIntrinsics kVga = CameraIntrinsics::thesisDefault(640, 480);
const CameraIntrinsics kQqvga = CameraIntrinsics::thesisDefault(160, 120);

double range(double depth, double lateral, double below)
{
  return std::sqrt(depth * depth + lateral * lateral + below * below);
}
}  // namespace

TEST(SpoolDetector, MeasuresACentredSpoolAt640x480)
{
  SpoolDetector detector;
  const DrawnSpool s = spoolAt(kVga, 0.8, 0.0, 0.06);
  const SpoolDetection d = detector.detect(drawScene({640, 480}, {s}), PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_TRUE(detector.usingFallbackCamera());
  EXPECT_NEAR(d.flange.x, s.x, 0.5);
  EXPECT_NEAR(d.flange.y, s.y, 0.5);
  EXPECT_NEAR(d.hole.r, s.hole_r, 0.5);
  EXPECT_NEAR(d.distance, 0.8, 0.01 * 0.8);  // depth
  EXPECT_NEAR(d.range, range(0.8, 0, 0.06), 0.01 * 0.8);
  EXPECT_NEAR(d.yaw, 0.0, 0.1 * M_PI / 180);
  EXPECT_TRUE(d.overlapped);
  EXPECT_FALSE(d.aligned);  // 80 cm is outside the insertion window
  EXPECT_GE(d.time_ms, 0.0);
}

TEST(SpoolDetector, AlignedInTheInsertionWindow)
{
  SpoolDetector detector;
  // At 55 cm the 35 cm flange (r = 255 px) is cut by the top and bottom of a 640x480 frame.
  const SpoolDetection d = detector.detect(drawScene({640, 480}, {spoolAt(kVga, 0.55, 0.0, 0.06)}), PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_NEAR(d.distance, 0.55, 0.01 * 0.55);  // depth
  EXPECT_NEAR(d.range, range(0.55, 0, 0.06), 0.01 * 0.55);
  EXPECT_TRUE(d.aligned);

  // 4 mm sideways is more than the 2.5 mm clearance.
  const SpoolDetection off =
      detector.detect(drawScene({640, 480}, {spoolAt(kVga, 0.55, 0.004, 0.06)}), PixelFormat::kBgr8);
  ASSERT_TRUE(off.detected);
  EXPECT_NEAR(off.lateral_offset, 0.004, 0.001);
  EXPECT_FALSE(off.aligned);
}

TEST(SpoolDetector, YawAndLateralOffsetOfAnOffsetSpool)
{
  SpoolDetector detector;
  const SpoolDetection d = detector.detect(drawScene({640, 480}, {spoolAt(kVga, 0.9, 0.12, 0.06)}), PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_NEAR(d.yaw, std::atan(0.12 / 0.9), 0.1 * M_PI / 180);
  EXPECT_NEAR(d.lateral_offset, 0.12, 0.003);
  EXPECT_NEAR(d.distance, 0.9, 0.01 * 0.9);  // depth
  EXPECT_NEAR(d.range, range(0.9, 0.12, 0.06), 0.01 * 0.9);
  EXPECT_FALSE(d.overlapped);
}

TEST(SpoolDetector, WorksAt160x120WithACalibratedCamera)
{
  SpoolDetector detector;
  CameraIntrinsics k = kQqvga;
  k.fx = k.fy = 210.0;
  detector.setCamera(k);
  const DrawnSpool s = spoolAt(k, 0.7, -0.03, 0.06);
  const SpoolDetection d = detector.detect(drawScene({160, 120}, {s}), PixelFormat::kBgr8);
  EXPECT_FALSE(detector.usingFallbackCamera());
  ASSERT_TRUE(d.detected);
  EXPECT_TRUE(d.hole_detected);
  EXPECT_NEAR(d.distance, 0.7, 0.02 * 0.7);  // depth
  EXPECT_NEAR(d.range, range(0.7, -0.03, 0.06), 0.02 * 0.7);
  EXPECT_LT(d.yaw, 0.0);
}

TEST(SpoolDetector, TargetsTheSpoolInFrontAmongNeighbours)
{
  SpoolDetector detector;
  // Neighbours 35 cm + 3 cm gap to each side at 1 m: only parts of them are in view.
  const DrawnSpool centre = spoolAt(kVga, 1.0, 0.02, 0.06);
  const DrawnSpool left = spoolAt(kVga, 1.0, 0.02 - 0.38, 0.06);
  const DrawnSpool right = spoolAt(kVga, 1.0, 0.02 + 0.38, 0.06);
  const SpoolDetection d = detector.detect(drawScene({640, 480}, {left, centre, right}), PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_NEAR(d.flange.x, centre.x, 1.0);
  EXPECT_TRUE(d.hole_detected);
}

TEST(SpoolDetector, AGlossyFaceLighterThanTheShelfIsFoundByTheSecondFlangeSearch)
{
  // A lamp's sheen lifts the face above a dark shelf: the rim's polarity is reversed, and the
  // bore is a darker disc in it.
  const DrawnSpool s = spoolAt(kVga, 0.8, 0.03, 0.06);
  spool_vision::test::SceneStyle style;
  style.background = 60;
  style.flange = 150;
  style.hole = 20;
  const cv::Mat img = drawScene({640, 480}, {s}, style);

  // Without the second flange search no flange circle leads to it; the bore nearest the
  // reference does (its rim measured by moving edges of either polarity).
  DetectorParams dark_only;
  dark_only.hough.flange_retry = spool_vision::FlangeRetry::kNone;
  const SpoolDetection bore_led = SpoolDetector(dark_only).detect(img, PixelFormat::kBgr8);
  ASSERT_TRUE(bore_led.detected);
  EXPECT_NEAR(bore_led.hole.x, s.x, 1.0);
  EXPECT_NEAR(bore_led.distance, 0.8, 0.01);

  const SpoolDetection d = SpoolDetector().detect(img, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_NEAR(d.flange.x, s.x, 1.0);
  EXPECT_NEAR(d.flange.y, s.y, 1.0);
  EXPECT_NEAR(d.flange.r, s.flange_r, 1.0);
  EXPECT_NEAR(d.hole.x, s.x, 1.0);
  EXPECT_NEAR(d.distance, 0.8, 0.01);

  // The usual dark face on a lighter shelf: the first search finds it.
  style.background = 170;
  style.flange = 35;
  const SpoolDetection first = SpoolDetector().detect(drawScene({640, 480}, {s}, style), PixelFormat::kBgr8);
  ASSERT_TRUE(first.detected);
  EXPECT_NEAR(first.flange.x, s.x, 1.0);
}

TEST(SpoolDetector, MeasuresAnObliqueSpoolWhoseBackFlangeShowsBesideIt)
{
  // 19 deg off the axis at 95 cm the back flange, 20 cm further, sticks out ~20 px on the inner
  // side and the plain rim fit follows both; the rim measured about the hole is the front one.
  SpoolDetector detector;
  detector.setCamera(kVga);
  const DrawnSpool front = spoolAt(kVga, 0.95, 0.33, 0.06);
  const DrawnSpool back = spoolAt(kVga, 1.15, 0.33, 0.06);
  ASSERT_LT(back.x - back.flange_r, front.x - front.flange_r - 15.0);
  const SpoolDetection d =
      detector.detect(drawScene({640, 480}, {{back.x, back.y, back.flange_r, 0.0}, front}), PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  ASSERT_TRUE(d.hole_detected);
  EXPECT_NEAR(d.flange.x, front.x, 1.0);
  EXPECT_NEAR(d.flange.y, front.y, 1.0);
  EXPECT_NEAR(d.flange.r_vertical, front.flange_r, 0.01 * front.flange_r);
  EXPECT_NEAR(d.distance, 0.95, 0.01 * 0.95);  // depth
  EXPECT_NEAR(d.range, range(0.95, 0.33, 0.06), 0.01 * 0.95);
  EXPECT_NEAR(d.yaw, std::atan(0.33 / 0.95), 0.1 * M_PI / 180);
}

TEST(SpoolDetector, MchtRejectsAFlangeWhoseOnlyHoleIsOffCentreWhereChtAcceptsIt)
{
  const DrawnSpool s = spoolAt(kVga, 0.8, 0.0, 0.06);
  cv::Mat img = drawScene({640, 480}, {{s.x, s.y, s.flange_r, 0.0}});
  // The real hole filled in, and a bright disc of hole size 30 px from the centre (a
  // reflection, say): beyond the concentric window, which at 0.8 m is 4 + 175^2/800*tan(0.44)
  // = 22 px.
  cv::Mat gray;
  cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  spool_vision::test::fillEllipse(gray, s.x, s.y, s.hole_r + 2, s.hole_r + 2, spool_vision::test::SceneStyle().flange);
  spool_vision::test::fillEllipse(gray, s.x + 30, s.y, s.hole_r, s.hole_r, 235);
  cv::cvtColor(gray, img, cv::COLOR_GRAY2BGR);
  SpoolDetector mcht;
  const SpoolDetection a = mcht.detect(img, PixelFormat::kBgr8);
  EXPECT_FALSE(a.detected);
  EXPECT_FALSE(a.hole_detected);
  EXPECT_TRUE(std::isnan(a.distance));

  DetectorParams p;
  p.matcher.mode = MatchMode::kCht;
  SpoolDetector cht(p);
  const SpoolDetection b = cht.detect(img, PixelFormat::kBgr8);
  ASSERT_TRUE(b.detected);
  ASSERT_TRUE(b.hole_detected);
  EXPECT_NEAR(b.hole.x, s.x + 30, 1.0);
}

TEST(SpoolDetector, AStrongFlangeWhoseBoreShowsOnlyAsADarkBlurIsASpoolWithLowConfidence)
{
  // 160x120 at 1.1 m: a dark bore 3.3 px in radius under a 2.5 px blur has no clean rim (a
  // 60-level step spread over 5 px), but it is a darker disc in the face on every side.
  const DrawnSpool s = spoolAt(kQqvga, 1.1, 0.0, 0.06);
  spool_vision::test::SceneStyle style;
  style.flange = 120;
  style.hole = 60;
  cv::Mat img;
  cv::GaussianBlur(drawScene({160, 120}, {s}, style), img, cv::Size(), 1.0);
  cv::Mat blurred_bore = img.clone();
  cv::Mat gray = drawScene({160, 120}, {{s.x, s.y, s.flange_r, 0.0}}, style);
  cv::GaussianBlur(gray, gray, cv::Size(), 1.0);
  cv::GaussianBlur(img, blurred_bore, cv::Size(), 2.5);
  // The face from the sharp image, the bore region from the strongly blurred one.
  cv::Mat mask(img.size(), CV_8UC1, cv::Scalar(0));
  cv::circle(mask, {cvRound(s.x), cvRound(s.y)}, cvRound(3 * s.hole_r), cv::Scalar(255), cv::FILLED);
  blurred_bore.copyTo(gray, mask);

  // Hole edges at 0.1 of full scale (a 13-level step per px): the blurred rim stays under it.
  DetectorParams bore;
  bore.hough.hole_edge_threshold = 0.1;
  DetectorParams hole_only = bore;
  hole_only.matcher.spool_evidence = spool_vision::SpoolEvidence::kHole;
  const SpoolDetection strict = SpoolDetector(hole_only).detect(gray, PixelFormat::kBgr8);
  ASSERT_FALSE(strict.hole_detected) << "the bore's rim must be too faint to fit for this test";
  EXPECT_FALSE(strict.detected);

  const SpoolDetection d = SpoolDetector(bore).detect(gray, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_FALSE(d.hole_detected);
  EXPECT_NEAR(d.flange.x, s.x, 1.0);
  EXPECT_LE(d.confidence, 0.5);
  EXPECT_GT(d.confidence, 0.4);  // 0.5 x a rim supported over 80% or more

  // The same flange without any bore (a plate) is no spool.
  cv::Mat plate = drawScene({160, 120}, {{s.x, s.y, s.flange_r, 0.0}}, style);
  cv::GaussianBlur(plate, plate, cv::Size(), 1.0);
  EXPECT_FALSE(SpoolDetector(bore).detect(plate, PixelFormat::kBgr8).detected);
}

TEST(SpoolDetector, ASharpBoreOfTheRightSizeDoesNotMakeItsFlangeARibRing)
{
  // A spool cut by the frame's border with a sharp bore, drawn as the ROS tests draw it
  // (test/ros/drawn_frames.py: cv::circle, anti-aliased, f = 800 px): a circle a pixel or two
  // larger than the bore was as well supported as the bore's own rim (the fit's band), which read
  // as "the bore is larger than the flange allows", and a ghost about the cut rim was taken as the
  // flange (0.87 m for 1.0 m).
  CameraIntrinsics camera = kVga;
  camera.fx = camera.fy = 800.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  SpoolDetector detector;
  detector.setCamera(camera);
  for (const double lateral : {0.26, 0.28, 0.3})
  {
    const DrawnSpool s = spoolAt(camera, 1.0, lateral, 0.06);
    ASSERT_GT(s.x + s.flange_r, 640.0);
    cv::Mat image(480, 640, CV_8UC1, cv::Scalar(170));
    constexpr int kShift = 4;
    const cv::Point centre(cvRound(s.x * (1 << kShift)), cvRound(s.y * (1 << kShift)));
    cv::circle(image, centre, cvRound(s.flange_r * (1 << kShift)), cv::Scalar(35), cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(image, centre, cvRound(s.hole_r * (1 << kShift)), cv::Scalar(235), cv::FILLED, cv::LINE_AA, kShift);
    const SpoolDetection d = detector.detect(image, PixelFormat::kMono8);
    SCOPED_TRACE("lateral " + std::to_string(lateral) + " m");
    ASSERT_TRUE(d.hole_detected);
    EXPECT_NEAR(d.flange.r, s.flange_r, 0.01 * s.flange_r);
    EXPECT_NEAR(d.distance, 1.0, 0.01);
  }
}

TEST(SpoolDetector, NothingOnAnEmptyShelf)
{
  SpoolDetector detector;
  const SpoolDetection d = detector.detect(drawScene({640, 480}, {}), PixelFormat::kBgr8);
  EXPECT_FALSE(d.detected);
  EXPECT_FALSE(d.hole_detected);
  EXPECT_TRUE(std::isnan(d.distance));
  EXPECT_TRUE(std::isnan(d.yaw));
  EXPECT_EQ(d.confidence, 0.0);
}

TEST(SpoolDetector, RejectsBadImagesClearly)
{
  SpoolDetector detector;
  EXPECT_THROW(detector.detect(cv::Mat(), PixelFormat::kBgr8), std::invalid_argument);
  EXPECT_THROW(detector.detect(cv::Mat(10, 10, CV_8UC3), PixelFormat::kBgr8), std::invalid_argument);
  EXPECT_THROW(detector.detect(cv::Mat(120, 160, CV_8UC1), PixelFormat::kBgr8), std::invalid_argument);
  EXPECT_THROW(detector.setCamera(CameraIntrinsics()), std::invalid_argument);
  DetectorParams bad;
  bad.hough.sensitivity = 2.0;
  EXPECT_THROW(detector.setParams(bad), spool_vision::ParamError);
  EXPECT_DOUBLE_EQ(detector.params().hough.sensitivity, DetectorParams().hough.sensitivity);
}

TEST(SpoolDetector, SteadyStateDoesNotAllocate)
{
  SpoolDetector detector;
  const cv::Mat img = drawScene({640, 480}, {spoolAt(kVga, 0.7, 0.01, 0.06)});
  detector.detect(img, PixelFormat::kBgr8);  // warm-up sizes every buffer
  detector.detect(img, PixelFormat::kBgr8);
  g_allocations = 0;
  g_counting = true;
  const SpoolDetection d = detector.detect(img, PixelFormat::kBgr8);
  g_counting = false;
  EXPECT_TRUE(d.detected);
  EXPECT_EQ(g_allocations.load(), 0);
}

TEST(SpoolDetector, AWindowAroundTheSpoolMeasuresItAsTheWholeFrameDoes)
{
  // Only the window's square is preprocessed and searched for edges; the spool inside it comes
  // out as the whole frame's search measures it, a neighbour outside it is not seen.
  SpoolDetector detector;
  const DrawnSpool target = spoolAt(kVga, 0.9, -0.05, 0.06);
  const DrawnSpool neighbour = spoolAt(kVga, 0.9, 0.55, 0.06);
  const cv::Mat frame = drawScene({640, 480}, {target, neighbour});
  const SpoolDetection whole = detector.detect(frame, PixelFormat::kBgr8);
  ASSERT_TRUE(whole.hole_detected);
  spool_vision::FlangeWindow window;
  window.centre = {whole.flange.x, whole.flange.y};
  window.radius = whole.flange.r;
  window.centre_margin = 6.0;
  window.radius_margin = 0.1 * whole.flange.r;
  const SpoolDetection windowed = detector.detect(frame, PixelFormat::kBgr8, window);
  ASSERT_TRUE(windowed.hole_detected);
  EXPECT_NEAR(windowed.flange.x, whole.flange.x, 0.02);
  EXPECT_NEAR(windowed.flange.y, whole.flange.y, 0.02);
  EXPECT_NEAR(windowed.flange.r, whole.flange.r, 0.02);
  EXPECT_NEAR(windowed.hole.x, whole.hole.x, 0.02);
  EXPECT_NEAR(windowed.distance, whole.distance, 1e-4);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(windowed.axis[i], whole.axis[i], 1e-4);
  // The preprocessed frame is blank beyond the window's reach (the neighbour's side).
  const cv::Mat& pre = detector.preprocessed();
  EXPECT_EQ(cv::countNonZero(pre(cv::Rect(600, 0, 40, 480))), 0);
  EXPECT_GT(cv::countNonZero(pre(cv::Rect(cvRound(whole.flange.x) - 5, cvRound(whole.flange.y) - 5, 10, 10))), 0);
}

TEST(SpoolDetector, ATrackedRimIsMeasuredAlongItAsTheWholeFrameMeasuresIt)
{
  // With the track's rim in the window the flange is measured by moving edges along it and only
  // the bore's surroundings are preprocessed; the spool comes out as the whole frame's search
  // measures it.
  SpoolDetector detector;
  const DrawnSpool target = spoolAt(kVga, 0.7, -0.04, 0.06);
  const cv::Mat frame = drawScene({640, 480}, {target, spoolAt(kVga, 0.7, 0.5, 0.06)});
  const SpoolDetection whole = detector.detect(frame, PixelFormat::kBgr8);
  ASSERT_TRUE(whole.hole_detected);
  spool_vision::FlangeWindow window;
  // The track 2% long and 2 mm to the side.
  const cv::Point3d predicted(whole.position.x + 0.002, whole.position.y, 1.02 * whole.position.z);
  window.centre = {kVga.fx * predicted.x / predicted.z + kVga.cx, kVga.fy * predicted.y / predicted.z + kVga.cy};
  window.radius = kVga.fy * 0.175 / predicted.z;
  window.centre_margin = 6.0;
  window.radius_margin = 0.1 * window.radius;
  window.rim = {predicted, {0.0, 0.0, 1.0}, 0.175};
  window.rim_reach = 8.0;
  window.bore_reach = 4.0;
  const SpoolDetection tracked = detector.detect(frame, PixelFormat::kBgr8, window);
  ASSERT_TRUE(tracked.hole_detected);
  EXPECT_NEAR(tracked.flange.x, target.x, 0.1);
  EXPECT_NEAR(tracked.flange.y, target.y, 0.1);
  EXPECT_NEAR(tracked.flange.r_vertical, target.flange_r, 0.1);
  EXPECT_NEAR(tracked.hole.x, whole.hole.x, 0.1);
  EXPECT_NEAR(tracked.hole.y, whole.hole.y, 0.1);
  EXPECT_NEAR(tracked.distance, whole.distance, 0.002 * whole.distance);
  EXPECT_NEAR(tracked.lateral_offset, whole.lateral_offset, 0.0005);
  // Nothing was preprocessed on the flange's rim, only about the bore.
  const cv::Mat& pre = detector.preprocessed();
  EXPECT_EQ(cv::countNonZero(pre(cv::Rect(cvRound(target.x - target.flange_r) - 5, cvRound(target.y) - 5, 10, 10))), 0);
  EXPECT_GT(cv::countNonZero(pre(cv::Rect(cvRound(target.x) - 5, cvRound(target.y) - 5, 10, 10))), 0);
  // A rim prediction 15% too large finds no rim within its reach: the window's Hough search
  // decides, exactly as in a window without a prediction.
  window.rim.radius = 0.175 * 1.15;
  const SpoolDetection fallback = detector.detect(frame, PixelFormat::kBgr8, window);
  spool_vision::FlangeWindow plain = window;
  plain.rim = spool_vision::RimPrediction();
  const SpoolDetection hough = detector.detect(frame, PixelFormat::kBgr8, plain);
  ASSERT_TRUE(fallback.hole_detected);
  EXPECT_DOUBLE_EQ(fallback.flange.r_vertical, hough.flange.r_vertical);
  EXPECT_DOUBLE_EQ(fallback.distance, hough.distance);
  EXPECT_NEAR(fallback.distance, whole.distance, 0.002 * whole.distance);
}

TEST(TrackingDetector, AWholeFrameRefusalIsCheckedOnTheNextFrame)
{
  // A track holds a neighbour 30 cm left (the only spool in view at first). Then the target comes
  // into view in front of the puller: the windows keep finding the neighbour, the next whole-frame
  // search finds the target and is refused. The frame after it is searched whole too, and the
  // second refusal in a row ends the track there, not track_full_search_interval frames later.
  const DrawnSpool target = spoolAt(kVga, 1.0, 0.02, 0.06);
  const DrawnSpool neighbour = spoolAt(kVga, 1.0, -0.30, 0.06);
  const cv::Mat alone = drawScene({640, 480}, {neighbour});
  const cv::Mat both = drawScene({640, 480}, {target, neighbour});
  spool_vision::TrackingDetector tracking;
  tracking.detector().setCamera(kVga);
  int frame = 0;
  for (; frame < 12; ++frame)
    tracking.process(alone, PixelFormat::kBgr8, frame / 30.0);
  ASSERT_EQ(tracking.tracker().current().state, spool_vision::TrackState::kTracking);
  int refused_at = -1;
  int lost_at = -1;
  for (; frame < 40 && lost_at < 0; ++frame)
  {
    const spool_vision::TrackedFrame f = tracking.process(both, PixelFormat::kBgr8, frame / 30.0);
    if (f.track.rejected_now && refused_at < 0)
    {
      EXPECT_TRUE(f.full_search);
      refused_at = frame;
    }
    if (f.track.state == spool_vision::TrackState::kLost)
      lost_at = frame;
  }
  ASSERT_GE(refused_at, 0);
  EXPECT_EQ(lost_at, refused_at + 1);
}

TEST(TrackingDetector, ATargetHintPicksTheTasksSpoolAmongNeighbours)
{
  // Two spools 1 m ahead: one 10 cm left of the puller (the image's nearest: the detector's own
  // target) and the slot the robot was sent to, 28 cm right. The hint puts the slot 4 cm off
  // its truth (the navigation's error) within 15 cm.
  const DrawnSpool near = spoolAt(kVga, 1.0, -0.10, 0.06);
  const DrawnSpool slot = spoolAt(kVga, 1.0, 0.28, 0.06);
  const cv::Mat image = drawScene({640, 480}, {near, slot});
  spool_vision::TrackingDetector without;
  without.detector().setCamera(kVga);
  const spool_vision::TrackedFrame own = without.process(image, PixelFormat::kBgr8, 0.0);
  ASSERT_TRUE(own.raw.detected);
  EXPECT_NEAR(own.raw.flange.x, near.x, 2.0);

  spool_vision::TrackingDetector hinted;
  hinted.detector().setCamera(kVga);
  const spool_vision::TargetHint hint{{0.28 + 0.04, 0.06, 1.0 - 0.03}, 0.15};
  // Frames 1 s apart: a young track's window then spans both spools; the hint still decides.
  for (int i = 0; i < 4; ++i)
  {
    const spool_vision::TrackedFrame f = hinted.process(image, PixelFormat::kBgr8, i * 1.0, std::nullopt, hint);
    ASSERT_TRUE(f.raw.detected) << i;
    EXPECT_NEAR(f.raw.flange.x, slot.x, 2.0) << i;
  }
  EXPECT_EQ(hinted.tracker().current().state, spool_vision::TrackState::kTracking);
  EXPECT_NEAR(hinted.tracker().current().position.x, 0.28, 0.01);

  // A track already on the neighbour when the hint comes is dropped; the slot is taken instead.
  for (int i = 1; i < 3; ++i)
    without.process(image, PixelFormat::kBgr8, i / 30.0);
  ASSERT_EQ(without.tracker().current().state, spool_vision::TrackState::kTracking);
  ASSERT_NEAR(without.tracker().current().position.x, -0.10, 0.01);
  for (int i = 3; i < 6; ++i)
    without.process(image, PixelFormat::kBgr8, i / 30.0, std::nullopt, hint);
  EXPECT_EQ(without.tracker().current().state, spool_vision::TrackState::kTracking);
  EXPECT_NEAR(without.tracker().current().position.x, 0.28, 0.01);

  // A hint where no spool is (between the two, or behind the camera): nothing is taken.
  spool_vision::TrackingDetector empty;
  empty.detector().setCamera(kVga);
  for (const cv::Point3d& at : {cv::Point3d(0.09, 0.06, 1.0), cv::Point3d(0.0, 0.06, -1.0)})
    EXPECT_FALSE(
        empty.process(image, PixelFormat::kBgr8, 0.0, std::nullopt, spool_vision::TargetHint{at, 0.05}).raw.detected)
        << at;
}
