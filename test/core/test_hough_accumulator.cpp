#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "spool_vision/hough_accumulator.h"
#include "synthetic.h"

using spool_vision::BackFlange;
using spool_vision::Circle;
using spool_vision::EdgeDetector;
using spool_vision::EdgePoint;
using spool_vision::EllipseShape;
using spool_vision::HoughAccumulator;
using spool_vision::HoughSearch;
using spool_vision::Polarity;
using spool_vision::test::drawSceneGray;
using spool_vision::test::SceneStyle;

namespace
{
constexpr std::size_t kNoBudget = std::numeric_limits<std::size_t>::max();

// Every edge of `gray` above `threshold` (no budget).
std::vector<EdgePoint> edgesOf(const cv::Mat& gray, double threshold)
{
  EdgeDetector detector;
  std::vector<EdgePoint> edges;
  detector.detect(gray, threshold, kNoBudget, edges);
  return edges;
}

// Every edge of `gray` blurred by a 1 px Gaussian (a lens's blur), above `threshold`.
std::vector<EdgePoint> blurredEdgesOf(const cv::Mat& gray, double threshold = 0.05)
{
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(), 1.0);
  return edgesOf(smooth, threshold);
}

// A search for dark rims of r_min..r_max px anywhere.
HoughSearch darkSearch(double r_min, double r_max)
{
  HoughSearch search;
  search.r_min = r_min;
  search.r_max = r_max;
  search.polarity = Polarity::kDark;
  return search;
}

std::vector<Circle> find(const cv::Mat& gray, double r_min, double r_max, Polarity polarity,
                         cv::Rect2d window = cv::Rect2d(), double threshold = 0.05)
{
  const std::vector<EdgePoint> points = blurredEdgesOf(gray, threshold);
  HoughSearch search;
  search.r_min = r_min;
  search.r_max = r_max;
  search.polarity = polarity;
  search.center_window = window;
  HoughAccumulator hough;
  std::vector<Circle> circles;
  hough.detect(points, gray.size(), search, circles);
  return circles;
}
}  // namespace

TEST(EdgeDetector, FindsAStepWithSubPixelPositionAndDirection)
{
  // A vertical step between columns 9 and 10 has its edge at x = 9.5.
  cv::Mat img(20, 20, CV_8UC1, cv::Scalar(50));
  img(cv::Rect(10, 0, 10, 20)).setTo(200);
  EdgeDetector detector;
  std::vector<EdgePoint> edges;
  detector.detect(img, 0.1, kNoBudget, edges);
  ASSERT_FALSE(edges.empty());
  for (const auto& e : edges)
  {
    EXPECT_NEAR(e.x, 9.5, 0.05);
    EXPECT_NEAR(e.dx, 1.0, 1e-3);  // dark to bright points right
    EXPECT_NEAR(e.dy, 0.0, 1e-3);
  }
  detector.detect(cv::Mat(20, 20, CV_8UC1, cv::Scalar(90)), 0.01, kNoBudget, edges);
  EXPECT_TRUE(edges.empty());
}

TEST(EdgeDetector, PlacesABlurredEdgeOfAGammaEncodedFrameWhereItsLightCrossesHalfWay)
{
  // A step of light at x = 30.3 (a dark bore beside a lit face), blurred by the lens
  // (sigma 2 px), encoded with a webcam's gamma of 0.45, then filtered as the detector filters.
  const double edge = 30.3;
  const double gamma = 0.45;
  cv::Mat light(40, 64, CV_64FC1);
  for (int x = 0; x < light.cols; ++x)
    light.col(x).setTo(0.02 + 0.78 * 0.5 * (1.0 + std::erf((x - edge) / (2.0 * std::sqrt(2.0)))));
  cv::Mat encoded;
  cv::pow(light, gamma, encoded);
  encoded.convertTo(encoded, CV_8UC1, 255.0);
  cv::Mat filtered;
  cv::GaussianBlur(encoded, filtered, cv::Size(), 1.5);

  std::array<float, 256> table{};
  for (std::size_t level = 0; level < table.size(); ++level)
    table[level] = static_cast<float>(std::pow(level / 255.0, 1.0 / gamma));
  const spool_vision::LinearLight linear{&encoded, table.data(), 4.5};
  EdgeDetector detector;
  detector.computeGradients(filtered);
  auto meanX = [&](const spool_vision::LinearLight* in_light)
  {
    std::vector<EdgePoint> edges;
    detector.extract(0.02, cv::Rect(0, 5, 64, 30), kNoBudget, edges, in_light);
    EXPECT_FALSE(edges.empty());
    double sum = 0.0;
    for (const auto& e : edges)
      sum += e.x;
    return sum / static_cast<double>(std::max<std::size_t>(edges.size(), 1));
  };
  // The gradient of the encoded frame peaks on the dark side; the light crosses half-way on the edge.
  EXPECT_LT(meanX(nullptr), edge - 0.3);
  EXPECT_NEAR(meanX(&linear), edge, 0.05);
}

TEST(EdgeDetector, KeepsTheStrongestEdgesWithinItsBudget)
{
  // Two vertical steps, a strong one (50 -> 200) and a weak one (200 -> 230): 18 rows each.
  cv::Mat img(20, 30, CV_8UC1, cv::Scalar(50));
  img(cv::Rect(10, 0, 20, 20)).setTo(200);
  img(cv::Rect(20, 0, 10, 20)).setTo(230);
  EdgeDetector detector;
  std::vector<EdgePoint> edges;
  detector.detect(img, 0.02, kNoBudget, edges);
  ASSERT_EQ(edges.size(), 36u);
  detector.detect(img, 0.02, 18, edges);
  ASSERT_EQ(edges.size(), 18u);
  for (const auto& e : edges)
    EXPECT_NEAR(e.x, 9.5, 0.05);  // only the strong step is left
  EXPECT_TRUE(
      std::is_sorted(edges.begin(), edges.end(), [](const EdgePoint& a, const EdgePoint& b) { return a.y < b.y; }));
  detector.detect(img, 0.02, 5, edges);
  EXPECT_EQ(edges.size(), 5u);
}

TEST(EdgeDetector, ANoiseFrameKeepsItsStrongestEdgesAtABoundedCost)
{
  // Faint noise passes the threshold almost everywhere (far more than 8 candidates per edge of
  // the budget, so the threshold rises); a strong step across it must still be what is kept.
  cv::Mat img(120, 160, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(img, cv::RNG::UNIFORM, 100, 120);
  img(cv::Rect(80, 0, 80, 120)) += cv::Scalar(100);
  EdgeDetector detector;
  std::vector<EdgePoint> edges;
  detector.detect(img, 0.005, kNoBudget, edges);
  ASSERT_GT(edges.size(), 8u * 118u);
  detector.detect(img, 0.005, 118, edges);
  ASSERT_EQ(edges.size(), 118u);
  for (const auto& e : edges)
    EXPECT_NEAR(e.x, 79.5, 1.0);
}

TEST(HoughAccumulator, FindsADarkCircleWithSubPixelAccuracy)
{
  const cv::Mat img = drawSceneGray({320, 240}, {{161.3, 118.7, 62.4, 0}});
  const auto circles = find(img, 40, 90, Polarity::kDark);
  ASSERT_FALSE(circles.empty());
  EXPECT_NEAR(circles[0].x, 161.3, 0.2);
  EXPECT_NEAR(circles[0].y, 118.7, 0.2);
  EXPECT_NEAR(circles[0].r, 62.4, 0.3);
  EXPECT_NEAR(circles[0].r_vertical, 62.4, 0.3);
  EXPECT_GT(circles[0].score, 0.8);
  EXPECT_NEAR(circles[0].visible_fraction, 1.0, 1e-9);
}

TEST(HoughAccumulator, PolaritySelectsDarkOrBrightDiscs)
{
  SceneStyle style;
  style.background = 40;
  style.flange = 220;  // a bright disc
  const cv::Mat img = drawSceneGray({200, 200}, {{100, 100, 30, 0}}, style);
  const auto bright = find(img, 20, 40, Polarity::kBright);
  ASSERT_EQ(bright.size(), 1u);
  EXPECT_NEAR(bright[0].r, 30, 0.3);
  EXPECT_TRUE(find(img, 20, 40, Polarity::kDark).empty());
}

TEST(HoughAccumulator, EitherPolarityAfterADarkSearchEqualsAnAnySearch)
{
  // A dark disc and a bright one: the dark search finds one, adding the bright votes both, as a
  // search of either polarity from scratch does.
  SceneStyle style;
  style.background = 120;
  style.flange = 30;
  cv::Mat img = drawSceneGray({300, 160}, {{80, 80, 32, 0}}, style);
  cv::circle(img, {220, 80}, 30, cv::Scalar(220), cv::FILLED, cv::LINE_AA);
  cv::GaussianBlur(img, img, cv::Size(), 1.0);
  const std::vector<EdgePoint> edges = edgesOf(img, 0.05);
  const HoughSearch search = darkSearch(20, 40);
  HoughAccumulator hough;
  std::vector<Circle> dark;
  hough.detect(edges, img.size(), search, dark);
  ASSERT_EQ(dark.size(), 1u);
  EXPECT_NEAR(dark[0].x, 80, 0.3);
  std::vector<Circle> either;
  hough.detectEitherPolarity(edges, img.size(), search, {}, either);

  HoughSearch any = search;
  any.polarity = Polarity::kAny;
  std::vector<Circle> scratch;
  HoughAccumulator().detect(edges, img.size(), any, scratch);
  ASSERT_EQ(either.size(), 2u);
  ASSERT_EQ(scratch.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i)
  {
    EXPECT_NEAR(either[i].x, scratch[i].x, 1e-3);
    EXPECT_NEAR(either[i].y, scratch[i].y, 1e-3);
    EXPECT_NEAR(either[i].r, scratch[i].r, 1e-3);
  }

  // Peaks only where asked: about the bright disc, the bright disc alone.
  hough.detect(edges, img.size(), search, dark);
  std::vector<Circle> near;
  hough.detectEitherPolarity(edges, img.size(), search, cv::Rect2d(180, 40, 80, 80), near);
  ASSERT_EQ(near.size(), 1u);
  const Circle& bright = either[0].x > 150 ? either[0] : either[1];
  EXPECT_NEAR(bright.x, 220, 0.3);
  EXPECT_NEAR(near[0].x, bright.x, 1e-3);
  EXPECT_NEAR(near[0].r, bright.r, 1e-3);

  // Only right after a detect() of that search: its votes are what is added to.
  HoughSearch other = search;
  other.r_max = 45;
  hough.detect(edges, img.size(), search, dark);
  EXPECT_THROW(hough.detectEitherPolarity(edges, img.size(), other, {}, either), std::logic_error);
  // Nothing voted (no edges), nothing found.
  hough.detect({}, img.size(), search, dark);
  hough.detectEitherPolarity({}, img.size(), search, {}, either);
  EXPECT_TRUE(either.empty());
}

TEST(HoughAccumulator, DetectAgainFindsAWeakRimFromTheSameVotes)
{
  // A whole dark disc and one whose rim shows only on its top 30% (a band of its own grey
  // covers the rest, as a touching neighbour's face does): asked for 0.45 of a rim, the search
  // finds the whole one; the same votes asked for 0.25 about the other find it too.
  SceneStyle style;
  style.background = 150;
  style.flange = 40;
  cv::Mat img = drawSceneGray({320, 160}, {{80, 80, 40, 0}, {230, 80, 40, 0}}, style);
  cv::rectangle(img, cv::Point(170, 56), cv::Point(300, 159), cv::Scalar(40), cv::FILLED);
  cv::GaussianBlur(img, img, cv::Size(), 1.0);
  const std::vector<EdgePoint> edges = edgesOf(img, 0.05);
  HoughSearch search = darkSearch(30, 50);
  search.min_score = 0.45;
  HoughAccumulator hough;
  std::vector<Circle> strong;
  hough.detect(edges, img.size(), search, strong);
  ASSERT_EQ(strong.size(), 1u);
  EXPECT_NEAR(strong[0].x, 80, 0.5);

  HoughSearch weaker = search;
  weaker.min_score = 0.25;
  std::vector<Circle> again;
  const cv::Rect2d centres(190, 40, 80, 80);
  hough.detectAgain(edges, img.size(), weaker, centres, again);
  ASSERT_FALSE(again.empty());
  // Best first; only peaks centred where asked are measured (the band's corner closes a weaker
  // ghost there), whose fits move them by a few px at most.
  const cv::Rect2d near_centres(centres.x - 4.0, centres.y - 4.0, centres.width + 8.0, centres.height + 8.0);
  for (const Circle& c : again)
    EXPECT_TRUE(near_centres.contains(cv::Point2d(c.x, c.y))) << c.x << ", " << c.y;
  EXPECT_NEAR(again[0].x, 230, 1.0);
  EXPECT_NEAR(again[0].y, 80, 1.0);
  EXPECT_NEAR(again[0].r, 40, 1.0);
  EXPECT_LT(again[0].score, 0.45);

  // Only the votes of that search: not another radius range, nor after the other polarity's.
  HoughSearch other = weaker;
  other.r_max = 45;
  EXPECT_THROW(hough.detectAgain(edges, img.size(), other, {}, again), std::logic_error);
  std::vector<Circle> either;
  hough.detectEitherPolarity(edges, img.size(), search, {}, either);
  EXPECT_THROW(hough.detectAgain(edges, img.size(), weaker, {}, again), std::logic_error);
}

TEST(HoughAccumulator, FindsAnArcCutByTheFrameBorder)
{
  // Centre 40 px right of the image, radius 120: about 40% of the rim is in view.
  const cv::Mat img = drawSceneGray({320, 240}, {{359.0, 120.0, 120.0, 0}});
  const auto circles = find(img, 80, 160, Polarity::kDark);
  ASSERT_FALSE(circles.empty());
  EXPECT_NEAR(circles[0].x, 359.0, 0.5);
  EXPECT_NEAR(circles[0].y, 120.0, 0.5);
  EXPECT_NEAR(circles[0].r, 120.0, 0.5);
  EXPECT_GT(circles[0].visible_fraction, 0.3);
  EXPECT_LT(circles[0].visible_fraction, 0.6);
}

TEST(HoughAccumulator, ToleratesNoise)
{
  SceneStyle style;
  style.noise_sigma = 10.0;
  const cv::Mat img = drawSceneGray({320, 240}, {{150.0, 110.0, 70.0, 0}}, style);
  const auto circles = find(img, 50, 90, Polarity::kDark, cv::Rect2d(), 0.08);
  ASSERT_FALSE(circles.empty());
  EXPECT_NEAR(circles[0].x, 150.0, 0.5);
  EXPECT_NEAR(circles[0].y, 110.0, 0.5);
  EXPECT_NEAR(circles[0].r, 70.0, 0.5);
}

TEST(HoughAccumulator, PrefersTheOuterRimOfConcentricRings)
{
  // A dark disc with a slightly lighter dark ring inside: both rims vote for one centre.
  cv::Mat img = drawSceneGray({320, 240}, {{160, 120, 90, 0}});
  spool_vision::test::fillEllipse(img, 160, 120, 62, 62, 20);
  spool_vision::test::fillEllipse(img, 160, 120, 58, 58, 35);  // a 4 px darker ring at r = 58..62
  const auto circles = find(img, 40, 110, Polarity::kDark);
  ASSERT_FALSE(circles.empty());
  EXPECT_NEAR(circles[0].r, 90.0, 0.5);
}

TEST(HoughAccumulator, SmallBrightHoleInsideAWindow)
{
  const cv::Mat img = drawSceneGray({160, 120}, {{80.4, 60.2, 40.0, 4.2}});
  const auto holes = find(img, 2.5, 8, Polarity::kBright, cv::Rect2d(76, 56, 8, 8));
  ASSERT_EQ(holes.size(), 1u);
  EXPECT_NEAR(holes[0].x, 80.4, 0.3);
  EXPECT_NEAR(holes[0].y, 60.2, 0.3);
  EXPECT_NEAR(holes[0].r, 4.2, 0.4);
}

TEST(HoughAccumulator, VerticalSemiAxisOfAStretchedRim)
{
  // A circle seen from a yawed camera is stretched horizontally by 1/cos(yaw); the vertical
  // axis is exact. 64/60 is a 21 degree bearing, just beyond the +-20 degree working range.
  cv::Mat img(240, 320, CV_8UC1, cv::Scalar(170));
  spool_vision::test::fillEllipse(img, 160.0, 120.0, 64.0, 60.0, 35);
  const auto circles = find(img, 40, 90, Polarity::kDark);
  ASSERT_FALSE(circles.empty());
  EXPECT_NEAR(circles[0].r_vertical, 60.0, 0.5);
  EXPECT_GT(circles[0].r, 61.0);
}

TEST(HoughAccumulator, NothingOnAnEmptyImage)
{
  EXPECT_TRUE(find(cv::Mat(120, 160, CV_8UC1, cv::Scalar(100)), 10, 50, Polarity::kDark).empty());
}

TEST(VisibleRimFraction, CountsTheRimInsideTheImage)
{
  EXPECT_NEAR(spool_vision::visibleRimFraction(50, 50, 20, {100, 100}), 1.0, 1e-9);
  EXPECT_NEAR(spool_vision::visibleRimFraction(-0.5, -0.5, 20, {100, 100}), 0.25, 0.02);
  EXPECT_NEAR(spool_vision::visibleRimFraction(99.5, 50, 20, {100, 100}), 0.5, 0.02);
  // The frame-only count (its own vector loop) and the loop with a back flange that hides nothing
  // (concentric, all but the front disc's size) count the same samples of a rim the border cuts.
  for (const auto& [x, y] : {std::pair{-0.5, 30.0}, std::pair{99.5, 50.0}, std::pair{80.0, 95.0}})
  {
    const BackFlange nothing_hidden{{x, y}, 1e-9};
    EXPECT_EQ(spool_vision::visibleRimFraction(x, y, 20, {100, 100}),
              spool_vision::visibleRimFraction(x, y, 20, {100, 100}, nothing_hidden))
        << x << ", " << y;
  }
}

TEST(BackFlange, HidesTheInnerSideOfAnObliqueFrontRim)
{
  // 640x480 thesis camera (f = 800 px), 35 cm flanges 20 cm apart.
  const BackFlange back{{320, 240}, 0.2 / (800 * 0.175)};
  const double k = back.scale(150);
  EXPECT_NEAR(k, 1.0 / (1.0 + 0.2 * 150 / 140), 1e-12);
  // Front rim 270 px right of the principal point: its back disc sits 270 * (1 - k) px inward.
  EXPECT_TRUE(back.hides(590, 258, 150, 590 - 150, 258));   // inner side: over the back disc
  EXPECT_FALSE(back.hides(590, 258, 150, 590 + 150, 258));  // outer side: against the wall
  EXPECT_FALSE(back.hides(590, 258, 150, 590, 258 - 150));  // top: the back disc is smaller
  const double can_show = spool_vision::visibleRimFraction(590, 258, 150, {2000, 2000}, back);
  EXPECT_GT(can_show, 0.6);
  EXPECT_LT(can_show, 0.9);
  // On the axis the back disc is concentric and smaller: the whole rim shows.
  EXPECT_NEAR(spool_vision::visibleRimFraction(320, 240, 150, {640, 480}, back), 1.0, 1e-9);
  EXPECT_FALSE(BackFlange().hides(590, 258, 150, 590 - 150, 258));
}

TEST(HoughAccumulator, FitAtMeasuresTheFrontRimAboutAKnownCentre)
{
  // An oblique spool at the right border: the back disc (drawn first) shows beside the front
  // one, and the plain fit follows their joint silhouette inward.
  const BackFlange back{{320, 240}, 0.2 / (800 * 0.175)};
  const double x = 585.3;
  const double y = 262.6;
  const double r = 150.4;
  const double k = back.scale(r);
  const cv::Mat img = drawSceneGray({640, 480}, {{320 + k * (x - 320), 240 + k * (y - 240), k * r, 0}, {x, y, r, 0}});
  const std::vector<EdgePoint> edges = blurredEdgesOf(img);
  HoughSearch search;
  search.r_min = 100;
  search.r_max = 200;
  HoughAccumulator hough;
  std::vector<Circle> fits;
  hough.detect(edges, img.size(), search, fits);
  ASSERT_FALSE(fits.empty());
  EXPECT_GT(x - fits.front().x, 5.0);  // the silhouette pulls the plain fit inward

  Circle front;
  ASSERT_TRUE(hough.fitAt(edges, img.size(), search, {x, y}, back, front));
  EXPECT_DOUBLE_EQ(front.x, x);
  EXPECT_DOUBLE_EQ(front.y, y);
  EXPECT_NEAR(front.r, r, 0.5);
  EXPECT_NEAR(front.r_vertical, front.r, 1e-12);
  EXPECT_NEAR(front.visible_fraction, spool_vision::visibleRimFraction(x, y, front.r, img.size()), 1e-12);
  // Scored against the rim that can show, the front rim is whole; against the whole in-frame
  // rim it is not.
  EXPECT_GT(front.score, 0.9);
  Circle plain;
  ASSERT_TRUE(hough.fitAt(edges, img.size(), search, {x, y}, BackFlange(), plain));
  EXPECT_LT(plain.score, front.score - 0.1);

  // Nothing about a centre with no rim around it in range.
  EXPECT_FALSE(hough.fitAt(edges, img.size(), search, {100, 100}, back, front));
}

TEST(HoughAccumulator, RefitOnMostSupportLeavesTheArcsBesideARimForTheRim)
{
  // A dark face (r 60 at (200, 150)) with two neighbours' dark discs touching its rim left and
  // right, 12 px lower: a circle through their near arcs and the top of the rim (r 66, 6 px
  // low) is where a fit from a coarse Hough cell can settle. Refitted, it is the rim.
  const double x = 200.0;
  const double y = 150.0;
  const double r = 60.0;
  const cv::Mat img = drawSceneGray(
      {400, 300}, {{x - 60.0 - 70.0, y + 12.0, 72.0, 0}, {x + 60.0 + 70.0, y + 12.0, 72.0, 0}, {x, y, r, 0}});
  const std::vector<EdgePoint> edges = blurredEdgesOf(img);
  HoughSearch search;
  search.r_min = 40;
  search.r_max = 90;
  HoughAccumulator hough;
  Circle fit;
  fit.x = x;
  fit.y = y + 6.0;
  fit.r = fit.r_horizontal = fit.r_vertical = 66.0;
  ASSERT_TRUE(hough.refitOnMostSupport(edges, img.size(), search, fit));
  EXPECT_NEAR(fit.x, x, 0.3);
  EXPECT_NEAR(fit.y, y, 0.3);
  EXPECT_NEAR(fit.r, r, 0.3);
  EXPECT_GT(fit.score, 0.9);

  // Nothing to refit where no edge is near.
  Circle empty = fit;
  empty.x = 60.0;
  empty.y = 60.0;
  empty.r = empty.r_horizontal = empty.r_vertical = 20.0;
  EXPECT_FALSE(hough.refitOnMostSupport(std::vector<EdgePoint>(), img.size(), search, empty));
}

TEST(HoughAccumulator, FitAtWithAnEmptyRadiusRangeFindsNothing)
{
  // A front rim measured about a hole with radii beyond the search range (found on a 1280x720
  // frame of clutter, where it threw std::length_error).
  const cv::Mat img = drawSceneGray({640, 480}, {{320, 240, 150, 0}});
  const std::vector<EdgePoint> edges = edgesOf(img, 0.05);
  HoughSearch search;
  search.r_min = 200;
  search.r_max = 120;
  HoughAccumulator hough;
  Circle c;
  EXPECT_FALSE(hough.fitAt(edges, img.size(), search, {320, 240}, BackFlange{}, c));
}

TEST(HoughAccumulator, FitCentreAtSizePlacesABlurredHalfRimToAFewHundredthsOfAPixel)
{
  // A bore's front rim at 55 cm (640x480): a lit disc in a dark face, blurred as the default
  // pre-filter blurs it (sigma 1.5 px), fitted on its upper half only with the rim's size known.
  // The bore's axis is read off this centre, 0.03 deg per 0.04 px.
  const double x = 320.37;
  const double y = 327.81;
  const double r = 26.2;
  const double sigma = 1.5;
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(40));
  spool_vision::test::fillEllipse(img, x, y, r, r, 200);
  cv::Mat smooth;
  cv::GaussianBlur(img, smooth, cv::Size(), sigma);
  const std::vector<EdgePoint> edges = edgesOf(smooth, 0.01);
  HoughSearch search;
  search.polarity = Polarity::kBright;
  HoughAccumulator hough;
  const cv::Point2d up(0.0, -1.0);
  const cv::Point2d start(x + 0.6, y - 0.8);
  // The blurred rim's gradient peaks sigma^2 / (2 r) inside it: searched for there, the centre
  // is found; searched for on the rim itself, the half rim pulls it inward (down) by that much.
  const double inset = 0.5 * sigma * sigma / r;
  Circle at_inset;
  ASSERT_TRUE(hough.fitCentreAtSize(edges, img.size(), search, start, {r - inset, r - inset}, 2.0, up, at_inset));
  EXPECT_NEAR(at_inset.x, x, 0.02);
  EXPECT_NEAR(at_inset.y, y, 0.02);
  Circle on_rim;
  ASSERT_TRUE(hough.fitCentreAtSize(edges, img.size(), search, start, {r, r}, 2.0, up, on_rim));
  EXPECT_GT(on_rim.y - y, 0.6 * inset);
  EXPECT_GT(at_inset.score, 0.9);
}

TEST(HoughAccumulator, FitCentreAndScaleMeasuresAHalfRimsOwnSizeWhereOnlyItsShapeIsKnown)
{
  // A dark bore seen ~35 deg off its axis (an ellipse 0.8 as wide as high), its far half hidden by
  // a lit wall band inside it: only the half facing left is its rim. Started from 0.87 of its
  // size (what a rib ring taken for the flange gives it) and off centre, the scale that the most
  // edges per px of rim support is its own, 1.15 times the start, within a step.
  const double x = 300.4;
  const double y = 250.7;
  const double semi_y = 24.0;
  const double semi_x = 0.8 * semi_y;
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(150));
  spool_vision::test::fillEllipse(img, x, y, semi_x, semi_y, 30);
  // The lit wall: the right part of the opening as light as the face.
  cv::rectangle(img, cv::Point(static_cast<int>(x + 0.3 * semi_x), 0), cv::Point(639, 479), cv::Scalar(150),
                cv::FILLED);
  const std::vector<EdgePoint> edges = blurredEdgesOf(img, 0.02);
  HoughSearch search;
  search.polarity = Polarity::kDark;
  HoughAccumulator hough;
  const double start_scale = 1.0 / 1.15;
  Circle own;
  ASSERT_TRUE(hough.fitCentreAndScale(edges, img.size(), search, {x + 2.0, y - 1.5},
                                      EllipseShape{semi_x, semi_y, 0.0}.scaled(start_scale), 6.0, {-1.0, 0.0}, 0.7,
                                      1.35, own));
  EXPECT_NEAR(own.r_vertical, semi_y, HoughAccumulator::kScaleStep * semi_y);
  EXPECT_NEAR(own.x, x, 0.5);
  EXPECT_NEAR(own.y, y, 0.5);
  // At the start's size the centre alone cannot put the half rim on it.
  Circle at_start;
  ASSERT_TRUE(hough.fitCentreAtSize(edges, img.size(), search, {x + 2.0, y - 1.5},
                                    EllipseShape{semi_x, semi_y, 0.0}.scaled(start_scale), 6.0, {-1.0, 0.0}, at_start));
  EXPECT_GT(std::abs(at_start.x - x), 1.5);
}

TEST(HoughAccumulator, FitCentreAtSizeCentresATiltedHalfRimOnItsOwnShape)
{
  // A dark bore seen ~35 deg off its axis and below its vanishing point (oblique seed 131 #8 at
  // 640x480: semi-axes 28.9 x 25.0 px, tilted 11 deg), its far half hidden by the lit wall: only
  // the half facing the vanishing point is its rim. Its own, tilted shape puts the centre on it;
  // the upright ellipse of the same semi-axes, fitted on that half, comes out off it.
  const double x = 300.4;
  const double y = 250.7;
  const EllipseShape shape{25.0, 28.9, 11.0 * M_PI / 180.0};
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(150));
  spool_vision::test::fillEllipse(img, x, y, shape.semi_x, shape.semi_y, 30, shape.tilt);
  // The lit wall: the opening beyond 0.3 of its short axis, away from the vanishing point, as
  // light as the face.
  const cv::Point2d away(std::cos(shape.tilt), std::sin(shape.tilt));
  for (int row = 0; row < img.rows; ++row)
    for (int col = 0; col < img.cols; ++col)
      if ((col - x) * away.x + (row - y) * away.y > 0.3 * shape.semi_x)
        img.at<uchar>(row, col) = 150;
  const std::vector<EdgePoint> edges = blurredEdgesOf(img, 0.02);
  HoughSearch search;
  search.polarity = Polarity::kDark;
  HoughAccumulator hough;
  const cv::Point2d start(x + 2.0, y - 1.5);
  Circle tilted;
  ASSERT_TRUE(hough.fitCentreAtSize(edges, img.size(), search, start, shape, 6.0, -away, tilted));
  EXPECT_NEAR(tilted.x, x, 0.25);
  EXPECT_NEAR(tilted.y, y, 0.25);
  EXPECT_NEAR(tilted.r, 0.5 * (shape.semi_x + shape.semi_y), 1e-9);
  EXPECT_NEAR(tilted.r_vertical, shape.halfHeight(), 1e-9);
  EXPECT_NEAR(tilted.r_horizontal, shape.halfWidth(), 1e-9);
  Circle upright;
  ASSERT_TRUE(
      hough.fitCentreAtSize(edges, img.size(), search, start, {shape.semi_x, shape.semi_y, 0.0}, 6.0, -away, upright));
  EXPECT_GT(std::hypot(upright.x - x, upright.y - y), 0.6);
}

TEST(HoughAccumulator, ShapeDensityPeaksAtTheBoresOwnAspect)
{
  // A dark bore seen 35 deg off its axis: an upright ellipse cos(35 deg) = 0.82 as wide as high,
  // started 1.5 px off its centre. Of the ellipses of its height, the one of its own width has the
  // most soft support per px of perimeter: more than the round one by over 10%, and more than
  // ones 8 deg either side of its angle.
  const double x = 300.4;
  const double y = 250.7;
  const double semi_y = 22.0;
  const double angle = 35.0 * M_PI / 180.0;
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(150));
  spool_vision::test::fillEllipse(img, x, y, std::cos(angle) * semi_y, semi_y, 30);
  const std::vector<EdgePoint> edges = blurredEdgesOf(img, 0.02);
  HoughSearch search;
  search.polarity = Polarity::kDark;
  HoughAccumulator hough;
  auto density = [&](double a) {
    return hough.shapeDensity(edges, search, {x + 1.0, y - 1.0}, {std::cos(a) * semi_y, semi_y, 0.0}, 2.2);
  };
  const double own = density(angle);
  EXPECT_GT(own, 1.1 * density(0.0));
  EXPECT_GT(own, density(angle - 8.0 * M_PI / 180.0));
  EXPECT_GT(own, density(angle + 8.0 * M_PI / 180.0));
  // No edge near the shape: nothing borne out.
  EXPECT_EQ(hough.shapeDensity(edges, search, {x + 200.0, y}, {semi_y, semi_y, 0.0}, 2.2), 0.0);
}

TEST(EdgeDetector, ARegionFindsTheWholeFramesEdgesInsideIt)
{
  SceneStyle style;
  const cv::Mat gray = drawSceneGray({200, 150}, {{100.0, 75.0, 50.0, 12.0}, {175.0, 30.0, 35.0, 8.0}}, style);
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(), 1.0);
  const std::vector<EdgePoint> whole = edgesOf(smooth, 0.05);
  for (const cv::Rect& region : {cv::Rect(40, 20, 90, 80), cv::Rect(0, 0, 70, 60), cv::Rect(150, 10, 80, 60)})
  {
    EdgeDetector detector;
    std::vector<EdgePoint> part;
    detector.detect(smooth, 0.05, kNoBudget, part, region);
    ASSERT_FALSE(part.empty()) << region;
    // Every edge found is the whole frame's, bit for bit; every whole-frame edge a pixel inside
    // the region is found (an edge's sub-pixel shift is at most half a pixel from its pixel).
    auto same = [](const EdgePoint& a, const EdgePoint& b)
    { return a.x == b.x && a.y == b.y && a.dx == b.dx && a.dy == b.dy; };
    for (const EdgePoint& e : part)
    {
      EXPECT_LE(std::hypot(e.x - std::clamp<float>(e.x, region.x, region.br().x - 1),
                           e.y - std::clamp<float>(e.y, region.y, region.br().y - 1)),
                0.5f);
      EXPECT_TRUE(std::any_of(whole.begin(), whole.end(), [&](const EdgePoint& w) { return same(e, w); }))
          << e.x << "," << e.y;
    }
    const cv::Rect well_inside(region.x + 1, region.y + 1, region.width - 2, region.height - 2);
    for (const EdgePoint& w : whole)
    {
      if (well_inside.contains({cvRound(w.x), cvRound(w.y)}))
      {
        EXPECT_TRUE(std::any_of(part.begin(), part.end(), [&](const EdgePoint& e) { return same(e, w); }))
            << w.x << "," << w.y;
      }
    }
    // Later extractions see only the region.
    std::vector<EdgePoint> later;
    detector.extract(0.05, cv::Rect(0, 0, smooth.cols, smooth.rows), kNoBudget, later);
    EXPECT_EQ(later.size(), part.size());
  }
}
