#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "spool_vision/camera_model.h"
#include "spool_vision/moving_edges.h"
#include "synthetic.h"

using spool_vision::CameraIntrinsics;
using spool_vision::Circle;
using spool_vision::MovingEdges;
using spool_vision::PixelFormat;
using spool_vision::RimPrediction;
using spool_vision::RimSearch;
using spool_vision::test::DrawnSpool;
using spool_vision::test::drawScene;
using spool_vision::test::SceneStyle;
using spool_vision::test::spoolAt;

namespace
{
const CameraIntrinsics kVga = CameraIntrinsics::thesisDefault(640, 480);
constexpr double kRimRadius = 0.175;  // m, the thesis spool's flange

// The rim of `spool` as a track would predict it with its depth `depth_error` (relative) and its
// centre `shift` px off: a flange facing the camera.
RimPrediction predictionOf(const DrawnSpool& spool, double depth_error, cv::Point2d shift)
{
  const double z = kVga.fy * kRimRadius / spool.flange_r * (1.0 + depth_error);
  RimPrediction p;
  p.centre = {(spool.x + shift.x - kVga.cx) * z / kVga.fx, (spool.y + shift.y - kVga.cy) * z / kVga.fy, z};
  p.axis = {0.0, 0.0, 1.0};
  p.radius = kRimRadius;
  return p;
}

RimSearch searchOf(double reach)
{
  RimSearch s;
  s.reach = reach;
  s.polarity = spool_vision::Polarity::kDark;
  s.threshold = 0.05;
  s.sigma = 1.2;
  return s;
}

MovingEdges edgesFor(const CameraIntrinsics& camera)
{
  MovingEdges edges;
  edges.setCamera(camera);
  return edges;
}
}  // namespace

TEST(MovingEdges, FindTheRimAPredictionMissedToATenthOfAPixel)
{
  // The track has the depth 3% long and the centre 3 px off: the rim moves 2-6 px along the normals.
  const DrawnSpool spool = spoolAt(kVga, 0.8, 0.02, 0.05);
  SceneStyle style;
  style.noise_sigma = 3.0;
  const cv::Mat frame = drawScene({640, 480}, {spool}, style);
  MovingEdges edges = edgesFor(kVga);
  Circle rim;
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, 0.03, {3.0, -2.0}), searchOf(9.0), rim));
  EXPECT_NEAR(rim.x, spool.x, 0.1);
  EXPECT_NEAR(rim.y, spool.y, 0.1);
  EXPECT_NEAR(rim.r_vertical, spool.flange_r, 0.1);
  EXPECT_NEAR(rim.r_horizontal, spool.flange_r, 0.1);
  EXPECT_GT(rim.score, 0.95);
  EXPECT_DOUBLE_EQ(rim.visible_fraction, 1.0);
  EXPECT_GE(edges.rimEdges().size(), 0.95 * edges.predictedRim().size());
}

TEST(MovingEdges, ARimBeyondTheReachIsNotFound)
{
  // The same rim 12 px outside the prediction, searched 5 px each way: no edge there.
  const DrawnSpool spool = spoolAt(kVga, 0.8, 0.0, 0.0);
  const cv::Mat frame = drawScene({640, 480}, {spool});
  MovingEdges edges = edgesFor(kVga);
  Circle rim;
  EXPECT_FALSE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, 12.0 / (spool.flange_r - 12.0), {}),
                             searchOf(5.0), rim));
}

TEST(MovingEdges, ALabelOverTheRimIsLeftOutOfTheFit)
{
  // A bright label over the top of the rim (a tenth of it) puts its own edges up to 8 px inside
  // the rim there: fitted, they would pull the centre 0.8 px down.
  const DrawnSpool spool = spoolAt(kVga, 0.8, 0.0, 0.0);
  cv::Mat frame = drawScene({640, 480}, {spool});
  const int top = cvRound(spool.y - spool.flange_r);
  cv::rectangle(frame, cv::Rect(cvRound(spool.x - 100), top - 20, 200, 28), cv::Scalar::all(250), cv::FILLED);
  MovingEdges edges = edgesFor(kVga);
  Circle rim;
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, 0.0, {}), searchOf(9.0), rim));
  EXPECT_NEAR(rim.x, spool.x, 0.15);
  EXPECT_NEAR(rim.y, spool.y, 0.15);
  EXPECT_NEAR(rim.r_vertical, spool.flange_r, 0.15);
  EXPECT_LT(rim.score, 0.97);  // the edges under the label are not the rim's
}

TEST(MovingEdges, ARimCutByTheFrameKeepsItsTrackedShape)
{
  // At 55 cm the flange overfills the frame: about 65% of its rim is in view. A free ellipse on
  // that arc trades its height for its width; the tracked shape moved and scaled does not.
  const DrawnSpool spool = spoolAt(kVga, 0.55, 0.0, 0.03);
  const cv::Mat frame = drawScene({640, 480}, {spool});
  MovingEdges edges = edgesFor(kVga);
  Circle rim;
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, -0.02, {2.0, 2.0}), searchOf(9.0), rim));
  EXPECT_LT(rim.visible_fraction, 0.8);
  EXPECT_NEAR(rim.x, spool.x, 0.15);
  EXPECT_NEAR(rim.y, spool.y, 0.15);
  EXPECT_NEAR(rim.r_vertical, spool.flange_r, 0.15);
  EXPECT_GT(rim.score, 0.9);  // of the samples inside the frame
}

TEST(MovingEdges, ARimCutByTheFrameIsSampledAsDenselyInViewAsAWholeOneWhenAsked)
{
  // The same cut rim: 96 samples round it leave about 60 in view; counted in view, as many are in
  // view as a whole rim would have (the cap is spread over the share that shows).
  const DrawnSpool spool = spoolAt(kVga, 0.55, 0.0, 0.03);
  const cv::Mat frame = drawScene({640, 480}, {spool});
  MovingEdges edges = edgesFor(kVga);
  Circle rim;
  RimSearch search = searchOf(9.0);
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, -0.02, {2.0, 2.0}), search, rim));
  const std::size_t around = edges.samplesInFrame();
  EXPECT_LT(around, 0.8 * search.max_samples);
  search.samples_in_view = true;
  Circle dense;
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, -0.02, {2.0, 2.0}), search, dense));
  EXPECT_GE(edges.samplesInFrame(), 0.9 * search.max_samples);
  EXPECT_NEAR(dense.r_vertical, spool.flange_r, 0.15);
  EXPECT_GT(dense.score, 0.9);
}

TEST(MovingEdges, OnlyARimCutByTheFrameAndSampledUnderItsSpacingIsSparseInView)
{
  RimSearch search = searchOf(9.0);
  Circle rim;
  // Cut by the frame at 55 cm (640x480): 96 samples of the ~250 its spacing gives, a third outside.
  const DrawnSpool cut = spoolAt(kVga, 0.55, 0.0, 0.03);
  MovingEdges edges = edgesFor(kVga);
  ASSERT_TRUE(edges.measure(drawScene({640, 480}, {cut}), PixelFormat::kBgr8, predictionOf(cut, 0.0, {}), search, rim));
  EXPECT_TRUE(edges.sparseInView());
  // Whole in the frame at 1 m: capped too, but every sample is inside.
  const DrawnSpool whole = spoolAt(kVga, 1.0, 0.0, 0.0);
  ASSERT_TRUE(
      edges.measure(drawScene({640, 480}, {whole}), PixelFormat::kBgr8, predictionOf(whole, 0.0, {}), search, rim));
  EXPECT_FALSE(edges.sparseInView());
  // Cut at 160x120: its ~80 samples at the spacing are all taken.
  const CameraIntrinsics qqvga = CameraIntrinsics::thesisDefault(160, 120);
  const DrawnSpool small = spoolAt(qqvga, 0.55, 0.0, 0.03);
  MovingEdges small_edges = edgesFor(qqvga);
  const RimPrediction small_rim{{(small.x - qqvga.cx) * 0.55 / qqvga.fx, (small.y - qqvga.cy) * 0.55 / qqvga.fy, 0.55},
                                {0.0, 0.0, 1.0},
                                kRimRadius};
  ASSERT_TRUE(small_edges.measure(drawScene({160, 120}, {small}), PixelFormat::kBgr8, small_rim, searchOf(3.0), rim));
  EXPECT_LT(rim.visible_fraction, 0.9);
  EXPECT_FALSE(small_edges.sparseInView());
}

TEST(MovingEdges, EveryPixelFormatGivesTheSameRim)
{
  const DrawnSpool spool = spoolAt(kVga, 0.8, -0.03, 0.02);
  const cv::Mat bgr = drawScene({640, 480}, {spool});
  cv::Mat gray, rgb, bgra, rgba, mono16;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  gray.convertTo(mono16, CV_16U, 257.0);
  const RimPrediction prediction = predictionOf(spool, 0.02, {1.0, 1.0});
  MovingEdges edges = edgesFor(kVga);
  Circle reference;
  ASSERT_TRUE(edges.measure(bgr, PixelFormat::kBgr8, prediction, searchOf(8.0), reference));
  const std::pair<const cv::Mat*, PixelFormat> frames[] = {{&gray, PixelFormat::kMono8},
                                                           {&rgb, PixelFormat::kRgb8},
                                                           {&bgra, PixelFormat::kBgra8},
                                                           {&rgba, PixelFormat::kRgba8},
                                                           {&mono16, PixelFormat::kMono16}};
  for (const auto& [frame, format] : frames)
  {
    Circle rim;
    ASSERT_TRUE(edges.measure(*frame, format, prediction, searchOf(8.0), rim)) << static_cast<int>(format);
    EXPECT_NEAR(rim.x, reference.x, 0.02) << static_cast<int>(format);
    EXPECT_NEAR(rim.y, reference.y, 0.02) << static_cast<int>(format);
    EXPECT_NEAR(rim.r, reference.r, 0.02) << static_cast<int>(format);
  }
}

TEST(MovingEdges, AHeldFramesGrayLevelsAreReadAgainUntilTheFrameEnds)
{
  // Between beginFrame() and endFrame(), measure() keeps the gray levels of the tiles its rims
  // reached: a later rim of the same frame reads them, and must come out exactly as a fresh
  // MovingEdges measures it.
  const DrawnSpool first = spoolAt(kVga, 0.8, -0.03, 0.02);
  const DrawnSpool second = spoolAt(kVga, 0.7, 0.04, -0.01);
  const cv::Mat first_frame = drawScene({640, 480}, {first});
  const cv::Mat second_frame = drawScene({640, 480}, {second});
  auto fresh = [](const cv::Mat& frame, const RimPrediction& prediction)
  {
    MovingEdges edges = edgesFor(kVga);
    Circle rim;
    EXPECT_TRUE(edges.measure(frame, PixelFormat::kBgr8, prediction, searchOf(8.0), rim));
    return rim;
  };
  auto expectSame = [](const Circle& rim, const Circle& expected)
  {
    EXPECT_EQ(rim.x, expected.x);
    EXPECT_EQ(rim.y, expected.y);
    EXPECT_EQ(rim.r_horizontal, expected.r_horizontal);
    EXPECT_EQ(rim.r_vertical, expected.r_vertical);
    EXPECT_EQ(rim.score, expected.score);
  };
  MovingEdges edges = edgesFor(kVga);
  cv::Mat frame = first_frame.clone();
  Circle rim;
  edges.beginFrame();
  // A rim predicted larger than the first reaches tiles the first did not, and some it did.
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(first, -0.02, {2.0, 0.0}), searchOf(8.0), rim));
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(first, 0.03, {0.0, 2.0}), searchOf(8.0), rim));
  expectSame(rim, fresh(first_frame, predictionOf(first, 0.03, {0.0, 2.0})));
  // Another frame in another buffer is noticed.
  ASSERT_TRUE(edges.measure(second_frame, PixelFormat::kBgr8, predictionOf(second, 0.02, {}), searchOf(8.0), rim));
  expectSame(rim, fresh(second_frame, predictionOf(second, 0.02, {})));
  // Another frame written into the same buffer is read once the frame held has ended, and
  // outside a held frame on every call.
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(first, 0.02, {}), searchOf(8.0), rim));
  second_frame.copyTo(frame);
  edges.endFrame();
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(second, 0.02, {}), searchOf(8.0), rim));
  expectSame(rim, fresh(second_frame, predictionOf(second, 0.02, {})));
  EXPECT_NEAR(rim.x, second.x, 0.1);
  first_frame.copyTo(frame);
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(first, 0.02, {}), searchOf(8.0), rim));
  expectSame(rim, fresh(first_frame, predictionOf(first, 0.02, {})));
}

TEST(MovingEdges, ALensBendsTheNormalsAndTheRimIsMeasuredUndistorted)
{
  // The frame through a barrel lens; the rim comes back in the undistorted image, where the
  // prediction lives.
  CameraIntrinsics lens = kVga;
  lens.distortion = {-0.25, 0.08, 0.0, 0.0, 0.0};
  const DrawnSpool spool = spoolAt(kVga, 0.8, 0.08, 0.04);
  const cv::Mat ideal = drawScene({640, 480}, {spool});
  // Each raw pixel shows the ideal image where the lens model sends it.
  cv::Mat table, frame;
  spool_vision::undistortionTable(lens, table);
  cv::remap(ideal, frame, table, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  MovingEdges edges = edgesFor(lens);
  Circle rim;
  ASSERT_TRUE(edges.measure(frame, PixelFormat::kBgr8, predictionOf(spool, 0.02, {-2.0, 1.0}), searchOf(9.0), rim));
  EXPECT_NEAR(rim.x, spool.x, 0.3);
  EXPECT_NEAR(rim.y, spool.y, 0.3);
  EXPECT_NEAR(rim.r_vertical, spool.flange_r, 0.3);
}

TEST(MovingEdges, NothingToFollowOrNothingAheadGivesNoRim)
{
  const cv::Mat blank(480, 640, CV_8UC3, cv::Scalar::all(128));
  const DrawnSpool spool = spoolAt(kVga, 0.8, 0.0, 0.0);
  MovingEdges edges = edgesFor(kVga);
  Circle rim;
  EXPECT_FALSE(edges.measure(blank, PixelFormat::kBgr8, predictionOf(spool, 0.0, {}), searchOf(9.0), rim));
  RimPrediction behind = predictionOf(spool, 0.0, {});
  behind.centre.z = -0.5;
  EXPECT_FALSE(edges.measure(blank, PixelFormat::kBgr8, behind, searchOf(9.0), rim));
  EXPECT_THROW(edges.measure(blank, PixelFormat::kMono8, predictionOf(spool, 0.0, {}), searchOf(9.0), rim),
               std::invalid_argument);
  EXPECT_THROW(edges.setCamera(CameraIntrinsics()), std::invalid_argument);
}
