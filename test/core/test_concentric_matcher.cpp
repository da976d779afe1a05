#include <gtest/gtest.h>

#include "spool_vision/concentric_matcher.h"

using spool_vision::Circle;
using spool_vision::ConcentricMatcher;
using spool_vision::MatcherParams;
using spool_vision::MatchMode;

namespace
{
constexpr double kRatio = 3.6 / 35.0;
Circle circle(double x, double y, double r, double score = 0.5)
{
  Circle c;
  c.x = x;
  c.y = y;
  c.r = c.r_vertical = r;
  c.score = score;
  return c;
}
MatcherParams params(MatchMode mode, double tol = 2.0)
{
  MatcherParams p;
  p.mode = mode;
  p.concentric_tolerance = tol;
  p.hole_ratio_tolerance = 0.3;
  return p;
}
}  // namespace

TEST(ConcentricMatcher, AcceptsAConcentricHoleOfTheRightSize)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kRatio);
  const Circle flange = circle(80, 60, 50);
  EXPECT_TRUE(m.accepts(flange, circle(81.5, 58.5, 50 * kRatio)));
}

TEST(ConcentricMatcher, RejectsAnOffCentreHole)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kRatio);
  const Circle flange = circle(80, 60, 50);
  EXPECT_FALSE(m.accepts(flange, circle(82.5, 60, 50 * kRatio)));
  EXPECT_FALSE(m.accepts(flange, circle(80, 57.4, 50 * kRatio)));
}

TEST(ConcentricMatcher, RejectsAWrongSizeRing)
{
  const ConcentricMatcher m(params(MatchMode::kMcht), kRatio);
  const Circle flange = circle(80, 60, 50);
  EXPECT_FALSE(m.accepts(flange, circle(80, 60, 50 * kRatio * 1.5)));  // a rib, not the bore
  EXPECT_FALSE(m.accepts(flange, circle(80, 60, 50 * kRatio * 0.5)));
}

TEST(ConcentricMatcher, ChtModeHasNoConstraintAndTakesTheStrongest)
{
  const ConcentricMatcher m(params(MatchMode::kCht), kRatio);
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
  const ConcentricMatcher m(params(MatchMode::kMcht), kRatio);
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
  // A weak circle must be nearer in proportion to its missing support: 20 px at 0.25 costs 80,
  // 60 px at 1.0 costs 60.
  ConcentricMatcher::orderByReference({circle(100, 50, 50, 0.25), circle(140, 50, 50, 1.0)}, {80, 50}, order);
  EXPECT_EQ(order, (std::vector<std::size_t>{1, 0}));
  ConcentricMatcher::orderByReference({}, {80, 50}, order);
  EXPECT_TRUE(order.empty());
}
