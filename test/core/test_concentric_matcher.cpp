#include <gtest/gtest.h>

#include "spool_vision/concentric_matcher.h"

using spool_vision::CameraIntrinsics;
using spool_vision::Circle;
using spool_vision::ConcentricMatcher;
using spool_vision::GeometryParams;
using spool_vision::HoughSearch;
using spool_vision::MatcherParams;
using spool_vision::MatchMode;

namespace
{
constexpr double kRatio = 3.6 / 35.0;
const GeometryParams kSpool;                                                 // 35 cm flange, 3.6 cm hole, 20 cm hub
const CameraIntrinsics kVga = CameraIntrinsics::thesisDefault(640, 480);     // f = 800 px, centre (319.5, 239.5)
const CameraIntrinsics kThesis = CameraIntrinsics::thesisDefault(160, 120);  // f = 200 px
Circle circle(double x, double y, double r, double score = 0.5)
{
  Circle c;
  c.x = x;
  c.y = y;
  c.r = c.r_vertical = r;
  c.score = score;
  c.visible_fraction = 1.0;
  return c;
}
// `tol` px at the camera's fy; the perspective widening off unless a test asks for it.
MatcherParams params(MatchMode mode, double tol = 2.0, const CameraIntrinsics& camera = kThesis)
{
  MatcherParams p;
  p.mode = mode;
  p.concentric_tolerance = tol / camera.fy;
  p.max_view_angle = p.max_view_pitch = 0.0;
  p.hole_ratio_tolerance = 0.3;
  return p;
}
}  // namespace

TEST(ConcentricMatcher, AcceptsAConcentricHoleOfTheRightSize)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kSpool, kThesis);
  const Circle flange = circle(80, 60, 50);
  EXPECT_TRUE(m.accepts(flange, circle(81.5, 58.5, 50 * kRatio)));
}

TEST(ConcentricMatcher, RejectsAnOffCentreHole)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kSpool, kThesis);
  const Circle flange = circle(80, 60, 50);
  EXPECT_FALSE(m.accepts(flange, circle(82.5, 60, 50 * kRatio)));
  EXPECT_FALSE(m.accepts(flange, circle(80, 57.4, 50 * kRatio)));
}

TEST(ConcentricMatcher, RejectsAHoleCutByTheImageBorder)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kSpool, kThesis);
  const Circle flange = circle(80, 60, 50);
  Circle hole = circle(80, 60, 50 * kRatio);
  hole.visible_fraction = 0.8;
  EXPECT_FALSE(m.accepts(flange, hole));
  hole.visible_fraction = 0.95;
  EXPECT_TRUE(m.accepts(flange, hole));
}

TEST(ConcentricMatcher, RejectsAWrongSizeRing)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kSpool, kThesis);
  const Circle flange = circle(80, 60, 50);
  EXPECT_FALSE(m.accepts(flange, circle(80, 60, 50 * kRatio * 1.5)));  // a rib, not the bore
  EXPECT_FALSE(m.accepts(flange, circle(80, 60, 50 * kRatio * 0.5)));
}

TEST(ConcentricMatcher, ChtModeHasNoConstraintAndTakesTheStrongest)
{
  const ConcentricMatcher m(params(MatchMode::kCht), kSpool, kThesis);
  const Circle flange = circle(80, 60, 50);
  const Circle far_strong = circle(20, 20, 9, 0.9);
  const Circle concentric_weak = circle(80, 60, 5, 0.4);
  EXPECT_TRUE(m.accepts(flange, far_strong));
  const auto hole = m.matchHole(flange, {concentric_weak, far_strong});
  ASSERT_TRUE(hole);
  EXPECT_DOUBLE_EQ(hole->x, 20);
}

TEST(ConcentricMatcher, MchtTakesTheNearestPassingHole)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kSpool, kThesis);
  const Circle flange = circle(80, 60, 50);
  const auto hole =
      m.matchHole(flange, {circle(81.8, 60, 5.1, 0.9), circle(80.2, 60.1, 5.2, 0.3), circle(20, 20, 5.1, 1.0)});
  ASSERT_TRUE(hole);
  EXPECT_DOUBLE_EQ(hole->x, 80.2);
  EXPECT_FALSE(m.matchHole(flange, {circle(20, 20, 5.1)}));
}

TEST(ConcentricMatcher, CandidatesAreTriedNearestTheReferenceFirst)
{
  std::vector<std::size_t> order{7};
  ConcentricMatcher::orderByReference({circle(20, 60, 50, 0.9), circle(90, 62, 50, 0.5), circle(150, 60, 50, 0.7)},
                                      {80, 50}, order);
  EXPECT_EQ(order, (std::vector<std::size_t>{1, 0, 2}));
  // A weak circle must be nearer in proportion to its missing support: 20 px at 0.25 (0.3125 of a
  // solid rim) costs 64, 60 px at 1.0 costs 60.
  ConcentricMatcher::orderByReference({circle(100, 50, 50, 0.25), circle(140, 50, 50, 1.0)}, {80, 50}, order);
  EXPECT_EQ(order, (std::vector<std::size_t>{1, 0}));
  // Two solid rims (kSolidRimScore and up) by distance alone: 27 px at 0.85 before 30 px at 1.0.
  ConcentricMatcher::orderByReference({circle(110, 50, 50, 1.0), circle(53, 50, 50, 0.85)}, {80, 50}, order);
  EXPECT_EQ(order, (std::vector<std::size_t>{1, 0}));
  ConcentricMatcher::orderByReference({}, {80, 50}, order);
  EXPECT_TRUE(order.empty());
}

TEST(ConcentricMatcher, DropsGhostsThatEncloseASolidRimOffTheirCentre)
{
  // Shelf boards and neighbours' arcs close a big weak circle around a real rim: it goes. A
  // circle about a concentric smaller one (its bore, a rib), a strong circle about a weaker one,
  // and one that a solid rim only overlaps (a neighbour) stay.
  std::vector<Circle> flanges{circle(100, 60, 80, 0.5),  circle(130, 60, 40, 0.9),   // ghost, rim
                              circle(300, 60, 80, 0.5),  circle(302, 60, 40, 0.95),  // concentric
                              circle(500, 60, 80, 0.95), circle(530, 60, 40, 0.6),   // strong outside
                              circle(700, 60, 80, 0.5),  circle(770, 60, 40, 0.9)};  // overlap
  ConcentricMatcher::dropEnclosingGhosts(flanges);
  std::vector<double> kept;
  for (const Circle& c : flanges)
    kept.push_back(c.x);
  EXPECT_EQ(kept, (std::vector<double>{130, 300, 302, 500, 530, 700, 770}));
  // The solid rim may come from another list (the first search's candidates).
  std::vector<Circle> ghost{circle(100, 60, 80, 0.5)};
  ConcentricMatcher::dropEnclosingGhosts(ghost, {circle(130, 60, 40, 0.9)});
  EXPECT_TRUE(ghost.empty());
  std::vector<Circle> none;
  ConcentricMatcher::dropEnclosingGhosts(none);
  EXPECT_TRUE(none.empty());
}

TEST(ConcentricMatcher, HoleWindowWidensOutwardForTheBackFlange)
{
  const MatcherParams p = params(MatchMode::kMcht, 4.0, kVga);
  const ConcentricMatcher m(p, kSpool, kVga);
  // On the optical axis the back flange hides behind the front one: no widening.
  const Circle on_axis = circle(kVga.cx, kVga.cy, 150);
  EXPECT_DOUBLE_EQ(m.silhouetteShift(on_axis).width, 0.0);
  EXPECT_DOUBLE_EQ(m.silhouetteShift(on_axis).height, 0.0);
  // 230 px right of the axis at r = 150 px (Z = 0.93 m): the back disc, 20 cm further, would be
  // (Z + L) / Z = 1 + 0.2 * 150 / (800 * 0.175) = 1.214 smaller and 230 * 0.214 px further in.
  const Circle right = circle(kVga.cx + 230, kVga.cy, 150);
  EXPECT_NEAR(m.backToFront(right), 1.0 + 0.2 * 150 / (800 * 0.175), 1e-12);
  EXPECT_NEAR(m.silhouetteShift(right).width, 230 * 0.2 * 150 / (800 * 0.175), 1e-9);
  HoughSearch search;
  search.r_max = 1000;
  ASSERT_TRUE(m.narrowHoleSearch(right, {640, 480}, search));
  EXPECT_NEAR(right.x - search.center_window.x, 4.0, 1e-6);  // inward: the tolerance alone
  EXPECT_NEAR(search.center_window.x + search.center_window.width - right.x, 4.0 + 230 * 0.2143, 0.1);
  // The hole of a front flange up to 1.214 times the fitted disc is searched for.
  EXPECT_NEAR(search.r_max, kRatio * 150 * 1.3 * m.backToFront(right), 1e-9);
  // Without a hub length (the thesis) nothing is known of the back flange.
  GeometryParams flat = kSpool;
  flat.hub_length = 0.0;
  const ConcentricMatcher no_hub(p, flat, kVga);
  EXPECT_DOUBLE_EQ(no_hub.silhouetteShift(right).width, 0.0);
  EXPECT_DOUBLE_EQ(no_hub.backToFront(right), 1.0);
}

TEST(ConcentricMatcher, ARimAboutTheHoleMustExplainTheFitThatLedToIt)
{
  MatcherParams p = params(MatchMode::kMcht, 4.0, kVga);
  p.max_view_angle = 0.44;
  p.max_view_pitch = 0.05;
  const ConcentricMatcher m(p, kSpool, kVga);
  const Circle front = circle(kVga.cx + 270, kVga.cy + 20, 150);
  const double k = m.backFlange().scale(150);
  const Circle back = circle(kVga.cx + k * 270, kVga.cy + k * 20, k * 150);
  const Circle between = circle(0.5 * (front.x + back.x), 0.5 * (front.y + back.y), 0.5 * (front.r + back.r));
  EXPECT_TRUE(m.explainsFit(front, front));
  EXPECT_TRUE(m.explainsFit(front, back));
  EXPECT_TRUE(m.explainsFit(front, between));
  // Outward of the front disc, or bigger than it: some other round mark, not this spool.
  EXPECT_FALSE(m.explainsFit(front, circle(front.x + 40, front.y, 150)));
  EXPECT_FALSE(m.explainsFit(front, circle(between.x, between.y, 1.2 * 150)));
  EXPECT_FALSE(m.explainsFit(front, circle(back.x, back.y, 0.8 * back.r)));
}

TEST(ConcentricMatcher, ATurnedSpoolsHoleIsLookedForWhereItsAxisShows)
{
  // A rim turned 20 degrees at 1 m (640x480): 133 x 142 px, its ellipse centre 9 px beside the
  // axis. A larger concentric ring (a rib) sits on the ellipse centre; the bore of the right size
  // where the axis shows wins. A round rim keeps the nearest rule.
  MatcherParams p = params(MatchMode::kMcht, 4.0, kVga);
  p.max_view_angle = 0.45;
  p.hole_ratio_tolerance = 0.4;
  const ConcentricMatcher matcher(p, kSpool, kVga);
  Circle flange = circle(380.0, 250.0, 137.5, 1.0);
  flange.r_vertical = 142.0;
  flange.r_horizontal = 142.0 * std::cos(20.0 * M_PI / 180.0);
  const double shift = matcher.axisShift(flange);
  EXPECT_NEAR(shift, 142.0 * 142.0 / 800.0 * std::sin(20.0 * M_PI / 180.0) * std::cos(20.0 * M_PI / 180.0), 1e-9);
  const double bore = matcher.holeRadius(flange);
  const Circle rib = circle(380.5, 250.0, 1.35 * bore);
  const Circle hole = circle(380.0 - shift, 250.2, bore);
  ASSERT_TRUE(matcher.accepts(flange, rib));
  ASSERT_TRUE(matcher.accepts(flange, hole));
  EXPECT_NEAR(matcher.matchHole(flange, {rib, hole})->x, hole.x, 1e-9);
  flange.r_horizontal = flange.r_vertical;
  EXPECT_EQ(matcher.axisShift(flange), 0.0);
}
