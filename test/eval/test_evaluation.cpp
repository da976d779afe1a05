#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "spool_vision/eval/evaluation.h"
#include "spool_vision/io/config_io.h"

namespace sv = spool_vision;

namespace
{
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const sv::CameraIntrinsics kVga = sv::CameraIntrinsics::thesisDefault(640, 480);

sv::ProjectedCircle circleAt(double x, double y, double r, double visible = 1.0)
{
  sv::ProjectedCircle c;
  c.x = c.centre_x = x;
  c.y = c.centre_y = y;
  c.r = c.semi_major = c.semi_minor = c.r_vertical = r;
  c.visible_fraction = visible;
  return c;
}

double bearingOf(double x)
{
  return std::atan((x - kVga.cx) / kVga.fx);
}

// The slot's spool at 80 cm seen at column x, its bore lit and in view.
sv::GroundTruth slotSpool(double x)
{
  sv::GroundTruth t;
  t.kind = sv::SceneKind::kSpool;
  t.camera = kVga;
  t.flange = circleAt(x, 280.0, 175.0);
  t.hole = circleAt(x, 280.0, 18.0);
  t.distance = 0.8;
  t.yaw = bearingOf(x);
  t.flange_half_visible = t.hole_in_view = t.bore_visible = t.spool_centre_in_view = true;
  return t;
}

// A frame with no spool in the slot (a plate, say).
sv::GroundTruth emptySlot()
{
  sv::GroundTruth t;
  t.kind = sv::SceneKind::kPlate;
  t.camera = kVga;
  return t;
}

void addNeighbour(sv::GroundTruth& t, double x)
{
  t.neighbours.push_back({circleAt(x, 280.0, 170.0, 0.6), 0.82, bearingOf(x)});
}

sv::Circle circleOf(const sv::ProjectedCircle& c, double dx = 0.0, double dr = 0.0)
{
  sv::Circle out;
  out.x = c.x + dx;
  out.y = c.y;
  out.r = out.r_vertical = c.r + dr;
  out.score = 0.9;
  return out;
}

sv::SpoolDetection flangeAt(const sv::Circle& flange, double distance = 0.8, double yaw = 0.0)
{
  sv::SpoolDetection d;
  d.detected = true;
  d.flange = flange;
  d.distance = distance;
  d.yaw = yaw;
  d.time_ms = 1.0;
  return d;
}

// `detection` with `hole` reported as its hole rim.
sv::SpoolDetection withHole(sv::SpoolDetection detection, const sv::Circle& hole)
{
  detection.hole_detected = true;
  detection.hole = hole;
  return detection;
}

sv::DetectorParams config(const std::string& name)
{
  sv::DetectorParams params;
  sv::loadParamsYaml(std::string(SPOOL_CONFIG_DIR) + "/" + name, params);
  return params;
}

// Frame `index` of `count` of `set` drawn from `seed`, as setFrame() draws it.
struct DrawnFrame
{
  sv::SceneParams scene;
  sv::CameraPose pose;
};
DrawnFrame drawn(sv::FrameSet set, std::uint64_t seed, int index, int count)
{
  DrawnFrame f;
  sv::setFrame(set, seed, index, count, f.scene, f.pose);
  return f;
}
}  // namespace

TEST(LabelledSets, EachSetHasOneNameThatReadsBack)
{
  std::set<std::string> names;
  for (sv::FrameSet set : {sv::FrameSet::kMain, sv::FrameSet::kApproach, sv::FrameSet::kNegatives, sv::FrameSet::kHard,
                           sv::FrameSet::kDistorted, sv::FrameSet::kApproachHard, sv::FrameSet::kOblique,
                           sv::FrameSet::kPacked, sv::FrameSet::kPackedOblique})
  {
    const std::string name = sv::toString(set);
    names.insert(name);
    EXPECT_EQ(sv::frameSetNamed(name), set) << name;
  }
  EXPECT_EQ(names, (std::set<std::string>{"main", "approach", "negatives", "hard", "distorted", "approach_hard",
                                          "oblique", "packed", "packed_oblique"}));
  EXPECT_FALSE(sv::frameSetNamed("Main").has_value());
  EXPECT_FALSE(sv::frameSetNamed("").has_value());
}

TEST(LabelledSets, TheObliqueSetSeesItsSpools25To40DegreesOffTheirAxis)
{
  // The truth's own geometry, not the pose the set drew: the angle between the line of sight to
  // the bore's front centre and the spool axis, and the bearing.
  const sv::SpoolRenderer renderer(sv::setCamera(sv::FrameSet::kOblique, {160, 120}));
  int spools = 0;
  int left = 0;
  for (int i = 0; i < 40; ++i)
  {
    sv::SceneParams scene;
    sv::CameraPose pose;
    sv::setFrame(sv::FrameSet::kOblique, 5, i, 40, scene, pose);
    const sv::GroundTruth t = renderer.groundTruth(scene, pose);
    if (t.kind != sv::SceneKind::kSpool)
      continue;
    ++spools;
    const cv::Vec3d sight = cv::normalize(cv::Vec3d(t.position.x, t.position.y, t.position.z));
    const double view = std::acos(std::abs(sight.dot(t.axis))) * 180.0 / M_PI;
    EXPECT_NEAR(t.view_angle * 180.0 / M_PI, view, 1e-9) << i;
    EXPECT_GE(view, 24.0) << i;
    EXPECT_LE(view, 41.0) << i;
    EXPECT_LE(std::abs(t.yaw), 16.0 * M_PI / 180.0) << i;
    left += t.axis[0] * sight[2] - t.axis[2] * sight[0] > 0.0;
  }
  EXPECT_GE(spools, 28);
  // Both sides.
  EXPECT_GT(left, 0);
  EXPECT_LT(left, spools);
}

// The oblique set's frames on packed's shelf: the same camera beside the same slot, the shelf
// around it packed (1-3 neighbours each side), so that the target's neighbours are seen as far off
// their axes as it is.
TEST(LabelledSets, ThePackedObliqueSetIsTheObliqueSetsViewOfAPackedShelf)
{
  const sv::SpoolRenderer renderer(sv::setCamera(sv::FrameSet::kPackedOblique, {160, 120}));
  int spools = 0;
  for (int i = 0; i < 40; ++i)
  {
    const DrawnFrame oblique = drawn(sv::FrameSet::kOblique, 5, i, 40);
    const auto [scene, pose] = drawn(sv::FrameSet::kPackedOblique, 5, i, 40);
    EXPECT_EQ(pose.distance, oblique.pose.distance) << i;
    EXPECT_EQ(pose.yaw, oblique.pose.yaw) << i;
    EXPECT_EQ(pose.lateral, oblique.pose.lateral) << i;
    EXPECT_EQ(scene.kind, oblique.scene.kind) << i;
    // packShelf: at least one neighbour on each side, at most 3.
    const auto left = std::count_if(scene.neighbours.begin(), scene.neighbours.end(),
                                    [](const sv::NeighbourSpool& n) { return n.side < 0; });
    EXPECT_GE(left, 1) << i;
    EXPECT_LE(left, 3) << i;
    EXPECT_GE(static_cast<long>(scene.neighbours.size()) - left, 1) << i;
    EXPECT_LE(static_cast<long>(scene.neighbours.size()) - left, 3) << i;
    const sv::GroundTruth t = renderer.groundTruth(scene, pose);
    if (t.kind != sv::SceneKind::kSpool)
      continue;
    ++spools;
    EXPECT_GE(t.view_angle * 180.0 / M_PI, 24.0) << i;
    EXPECT_LE(t.view_angle * 180.0 / M_PI, 41.0) << i;
  }
  EXPECT_GE(spools, 28);
}

TEST(Statistics, PercentilesInterpolateBetweenOrderStatisticsAndSkipNaN)
{
  const std::vector<double> v = {5.0, 1.0, kNaN, 3.0, 2.0, std::numeric_limits<double>::infinity(), 4.0};
  EXPECT_DOUBLE_EQ(sv::percentile(v, 0.5), 3.0);
  EXPECT_DOUBLE_EQ(sv::percentile(v, 0.95), 4.8);
  EXPECT_DOUBLE_EQ(sv::percentile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(sv::percentile(v, 1.0), 5.0);
  EXPECT_DOUBLE_EQ(sv::percentile({1.0, 2.0}, 0.5), 1.5);
  EXPECT_TRUE(std::isnan(sv::percentile({}, 0.5)));
  EXPECT_TRUE(std::isnan(sv::percentile({kNaN, kNaN}, 0.5)));

  const sv::Spread s = sv::spreadOf(v);
  EXPECT_EQ(s.count, 5);
  EXPECT_DOUBLE_EQ(s.median, 3.0);
  EXPECT_DOUBLE_EQ(s.p95, 4.8);
}

TEST(Statistics, RateCountsOnlyEligibleFrames)
{
  sv::Rate r;
  EXPECT_TRUE(std::isnan(r.value()));
  r.add(true, true);
  r.add(true, false);
  r.add(false, true);
  EXPECT_EQ(r.frames, 2);
  EXPECT_EQ(r.hits, 1);
  EXPECT_DOUBLE_EQ(r.value(), 0.5);
}

TEST(Scoring, MatchTolerances)
{
  const sv::ProjectedCircle small = circleAt(100.0, 100.0, 20.0);
  EXPECT_TRUE(sv::flangeMatches(small, circleOf(small, 3.0)));  // 3 px floor
  EXPECT_FALSE(sv::flangeMatches(small, circleOf(small, 3.5)));
  const sv::ProjectedCircle big = circleAt(300.0, 200.0, 150.0);
  EXPECT_TRUE(sv::flangeMatches(big, circleOf(big, 14.5)));  // 10% of r
  EXPECT_FALSE(sv::flangeMatches(big, circleOf(big, 15.5)));
  EXPECT_TRUE(sv::flangeMatches(big, circleOf(big, 0.0, 14.5)));
  EXPECT_FALSE(sv::flangeMatches(big, circleOf(big, 0.0, -15.5)));

  const sv::HoleTolerance thesis = sv::holeTolerance(sv::CameraIntrinsics::thesisDefault(160, 120));
  const sv::ProjectedCircle hole = circleAt(50.0, 50.0, 4.0);
  EXPECT_TRUE(sv::holeMatches(hole, circleOf(hole, 2.0, 1.0), thesis));  // 2 px and 1 px floors
  EXPECT_FALSE(sv::holeMatches(hole, circleOf(hole, 2.5), thesis));
  EXPECT_FALSE(sv::holeMatches(hole, circleOf(hole, 0.0, 1.2), thesis));
  const sv::ProjectedCircle wide = circleAt(50.0, 50.0, 12.0);
  EXPECT_TRUE(sv::holeMatches(wide, circleOf(wide, 2.9, -2.9), thesis));  // 25% of r
  EXPECT_FALSE(sv::holeMatches(wide, circleOf(wide, 0.0, 3.1), thesis));
}

TEST(Scoring, TheHoleMustBeWithinOnePixelOfTheFrontRimFrom480Rows)
{
  const sv::HoleTolerance vga = sv::holeTolerance(kVga);
  EXPECT_DOUBLE_EQ(vga.centre_px, 1.0);
  EXPECT_DOUBLE_EQ(vga.radius_px, 1.0);
  EXPECT_DOUBLE_EQ(vga.centre_fraction, 0.0);
  EXPECT_DOUBLE_EQ(vga.radius_fraction, 0.0);
  const sv::HoleTolerance hd = sv::holeTolerance(sv::CameraIntrinsics::thesisDefault(1280, 720));
  EXPECT_DOUBLE_EQ(hd.centre_px, 1.5);  // the same angle as 1 px at 640x480
  const sv::HoleTolerance qvga = sv::holeTolerance(sv::CameraIntrinsics::thesisDefault(320, 240));
  EXPECT_DOUBLE_EQ(qvga.centre_px, 2.0);
  EXPECT_DOUBLE_EQ(qvga.radius_fraction, 0.25);

  const sv::ProjectedCircle hole = circleAt(330.0, 280.0, 18.0);
  EXPECT_TRUE(sv::holeMatches(hole, circleOf(hole, 0.9, -0.9), vga));
  EXPECT_FALSE(sv::holeMatches(hole, circleOf(hole, 1.2), vga));
  EXPECT_FALSE(sv::holeMatches(hole, circleOf(hole, 0.0, 1.2), vga));
  EXPECT_TRUE(sv::holeMatches(hole, circleOf(hole, 1.2, 1.2), qvga));

  // scoreFrame takes the tolerance from the frame's camera: 1.5 px off is no hole at 640x480.
  const sv::GroundTruth t = slotSpool(330.0);
  const sv::SpoolDetection d = withHole(flangeAt(circleOf(*t.flange)), circleOf(*t.hole, 1.5, 0.5));
  const sv::FrameScore off = sv::scoreFrame(t, d);
  EXPECT_TRUE(off.correct);
  EXPECT_FALSE(off.hole_correct);
  EXPECT_NEAR(off.hole_centre_error, 1.5, 1e-12);
  EXPECT_NEAR(off.hole_radius_error, 0.5, 1e-12);
}

TEST(Scoring, AHoleInViewButDarkCountsOnlyForTheDarkHoleRate)
{
  sv::GroundTruth dark = slotSpool(330.0);
  dark.bore_visible = false;
  const sv::SpoolDetection d = withHole(flangeAt(circleOf(*dark.flange)), circleOf(*dark.hole, 0.5));
  const sv::FrameScore found = sv::scoreFrame(dark, d);
  EXPECT_TRUE(found.hole_dark_eligible);
  EXPECT_FALSE(found.hole_eligible);
  EXPECT_TRUE(found.hole_correct);
  const sv::FrameScore missed = sv::scoreFrame(dark, flangeAt(circleOf(*dark.flange)));
  EXPECT_TRUE(missed.hole_dark_eligible);
  EXPECT_FALSE(missed.hole_correct);

  sv::GroundTruth out_of_view = dark;  // the opening not wholly in the frame: neither rate
  out_of_view.hole_in_view = false;
  const sv::FrameScore cut = sv::scoreFrame(out_of_view, d);
  EXPECT_FALSE(cut.hole_dark_eligible);
  EXPECT_FALSE(cut.hole_eligible);

  const sv::GroundTruth lit = slotSpool(330.0);
  const sv::Metrics m = sv::summarize({found, missed, cut, sv::scoreFrame(lit, d)});
  EXPECT_EQ(m.hole_found_dark.frames, 2);
  EXPECT_EQ(m.hole_found_dark.hits, 1);
  EXPECT_EQ(m.hole_found.frames, 1);
  EXPECT_EQ(m.hole_found.hits, 1);
  EXPECT_EQ(m.hole_centre_error_px.count, 2);  // eligible frames (lit or dark) with a hole reported
  EXPECT_NEAR(m.hole_centre_error_px.median, 0.5, 1e-12);
}

TEST(Scoring, ADetectionOnTheTargetIsCorrectAndMeasured)
{
  sv::GroundTruth t = slotSpool(330.0);
  addNeighbour(t, 330.0 + 380.0);  // centre out of view: not a neighbour "in view"
  const sv::SpoolDetection d =
      withHole(flangeAt(circleOf(*t.flange, 1.0), 0.808, t.yaw + 0.001), circleOf(*t.hole, 0.5));

  const sv::FrameScore s = sv::scoreFrame(t, d);
  EXPECT_TRUE(s.has_target);
  EXPECT_TRUE(s.flange_eligible);
  EXPECT_TRUE(s.hole_eligible);
  EXPECT_FALSE(s.neighbours_in_view);
  EXPECT_TRUE(s.correct);
  EXPECT_FALSE(s.on_other_spool);
  EXPECT_TRUE(s.hole_correct);
  EXPECT_NEAR(s.distance_error, 0.01, 1e-12);
  EXPECT_NEAR(s.yaw_error, 0.001, 1e-12);

  const sv::Metrics m = sv::summarize({s});
  EXPECT_EQ(m.flange_found.hits, 1);
  EXPECT_EQ(m.hole_found.hits, 1);
  EXPECT_EQ(m.false_hole.frames, 1);
  EXPECT_EQ(m.false_hole.hits, 0);
  EXPECT_EQ(m.wrong_target.frames, 0);
  EXPECT_NEAR(m.yaw_error_deg.median, 0.001 * 180.0 / M_PI, 1e-9);
}

TEST(Scoring, ADetectionOnANeighbourIsAWrongTarget)
{
  sv::GroundTruth t = slotSpool(330.0);
  addNeighbour(t, 600.0);  // in view, farther from the puller column than the slot's spool
  const sv::FrameScore s = sv::scoreFrame(t, flangeAt(circleOf(t.neighbours[0].flange)));
  EXPECT_TRUE(s.neighbours_in_view);
  EXPECT_TRUE(s.detected);
  EXPECT_FALSE(s.correct);
  EXPECT_TRUE(s.on_other_spool);
  EXPECT_TRUE(std::isnan(s.distance_error));

  const sv::Metrics m = sv::summarize({s});
  EXPECT_EQ(m.wrong_target.frames, 1);
  EXPECT_EQ(m.wrong_target.hits, 1);
  EXPECT_EQ(m.flange_found.frames, 1);
  EXPECT_EQ(m.flange_found.hits, 0);
  EXPECT_EQ(m.on_other_spool, 1);
  EXPECT_EQ(m.bogus, 0);
  EXPECT_EQ(m.distance_error.count, 0);
}

TEST(Scoring, TheTargetIsTheSpoolNearestThePullerColumn)
{
  sv::GroundTruth t = slotSpool(60.0);  // about -18 deg
  addNeighbour(t, 440.0);               // about +8.6 deg
  const auto target = sv::targetSpool(t);
  ASSERT_TRUE(target);
  EXPECT_FALSE(target->in_slot);
  EXPECT_DOUBLE_EQ(target->flange.x, 440.0);

  const sv::FrameScore on_neighbour = sv::scoreFrame(t, flangeAt(circleOf(t.neighbours[0].flange), 0.83));
  EXPECT_TRUE(on_neighbour.correct);
  EXPECT_NEAR(on_neighbour.distance_error, 0.01 / 0.82, 1e-12);  // against the neighbour's own truth
  EXPECT_FALSE(on_neighbour.hole_eligible);                      // its bore is not in the ground truth
  EXPECT_FALSE(on_neighbour.hole_judged);

  const sv::FrameScore on_slot = sv::scoreFrame(t, flangeAt(circleOf(*t.flange)));
  EXPECT_FALSE(on_slot.correct);
  EXPECT_TRUE(on_slot.on_other_spool);
  EXPECT_EQ(sv::summarize({on_slot}).wrong_target.hits, 1);
}

TEST(Scoring, ABackRowSpoolIsNeverTheTarget)
{
  // The puller reaches the front row: a back-row spool right in front of it (its face seen in
  // the gap beside the slot's spool) is another spool, and so are ties with it.
  sv::GroundTruth t = slotSpool(420.0);  // about +7 deg
  t.neighbours.push_back({circleAt(320.0, 280.0, 130.0), 1.05, bearingOf(320.0), true});
  const auto target = sv::targetSpool(t);
  ASSERT_TRUE(target);
  EXPECT_TRUE(target->in_slot);

  const sv::FrameScore on_back_row = sv::scoreFrame(t, flangeAt(circleOf(t.neighbours[0].flange), 1.05));
  EXPECT_FALSE(on_back_row.correct);
  EXPECT_TRUE(on_back_row.on_other_spool);
  EXPECT_TRUE(on_back_row.neighbours_in_view);
  EXPECT_NEAR(on_back_row.any_depth_error, 0.0, 1e-12);  // its depth is judged against its own truth
  EXPECT_EQ(sv::summarize({on_back_row}).wrong_target.hits, 1);
}

TEST(Scoring, ATargetSeenMoreThan40DegreesOffItsAxisIsOutsideTheFlangeBar)
{
  // The oblique set's camera beside the slot: a neighbour nearer the puller column than the slot's
  // spool (seen 37 deg off its axis) is the target, seen 57 deg off. It stays the target (a
  // detection on the slot's spool is a wrong target), but the flange bar, like 50-110 cm, asks it
  // only to 40 deg (issue 28).
  sv::GroundTruth t = slotSpool(420.0);  // about +7 deg
  t.view_angle = 37.0 * M_PI / 180.0;
  addNeighbour(t, 380.0);
  t.neighbours[0].view_angle = 57.0 * M_PI / 180.0;
  ASSERT_FALSE(sv::targetSpool(t)->in_slot);
  const sv::FrameScore missed = sv::scoreFrame(t, sv::SpoolDetection());
  EXPECT_FALSE(missed.flange_eligible);
  const sv::FrameScore on_slot = sv::scoreFrame(t, flangeAt(circleOf(*t.flange)));
  EXPECT_FALSE(on_slot.correct);
  EXPECT_EQ(sv::summarize({on_slot}).wrong_target.hits, 1);

  // At 40 deg it is asked.
  t.neighbours[0].view_angle = 39.0 * M_PI / 180.0;
  EXPECT_TRUE(sv::scoreFrame(t, sv::SpoolDetection()).flange_eligible);
}

TEST(Scoring, TwoSpoolsWithinOneDegreeOfTheSameBearingAreBothTheTarget)
{
  sv::GroundTruth t = slotSpool(319.5 + 120.0);  // +8.5 deg
  addNeighbour(t, 319.5 - 119.0);                // -8.5 deg, nearer by 0.07 deg: the target
  ASSERT_FALSE(sv::targetSpool(t)->in_slot);
  const sv::FrameScore on_slot = sv::scoreFrame(t, flangeAt(circleOf(*t.flange), 0.81));
  EXPECT_TRUE(on_slot.correct);
  EXPECT_FALSE(on_slot.on_other_spool);
  EXPECT_NEAR(on_slot.distance_error, 0.01 / 0.8, 1e-12);  // against the spool it lies on

  // The slot's spool the target, the detection on the tied neighbour: right, and its hole,
  // whose truth is not known, is neither found nor missed.
  sv::GroundTruth slot_first = slotSpool(319.5 - 119.0);
  addNeighbour(slot_first, 319.5 + 120.0);
  ASSERT_TRUE(sv::targetSpool(slot_first)->in_slot);
  const sv::SpoolDetection on_tied =
      withHole(flangeAt(circleOf(slot_first.neighbours[0].flange), 0.82), circleOf(*slot_first.hole, 239.0));
  const sv::FrameScore tied = sv::scoreFrame(slot_first, on_tied);
  EXPECT_TRUE(tied.correct);
  EXPECT_FALSE(tied.hole_eligible);
  EXPECT_FALSE(tied.hole_judged);
  EXPECT_EQ(sv::summarize({tied}).false_hole.frames, 0);

  t.neighbours.clear();
  addNeighbour(t, 319.5 - 100.0);  // -7.1 deg: 1.4 deg nearer, no longer a tie
  const sv::FrameScore not_tied = sv::scoreFrame(t, flangeAt(circleOf(*t.flange)));
  EXPECT_FALSE(not_tied.correct);
  EXPECT_TRUE(not_tied.on_other_spool);
}

TEST(Scoring, AFlangeOnNoSpoolIsBogus)
{
  sv::GroundTruth t = slotSpool(330.0);
  addNeighbour(t, 600.0);
  sv::Circle large;
  large.x = 320.0;
  large.y = 300.0;
  large.r = 260.0;
  const sv::Metrics m = sv::summarize({sv::scoreFrame(t, flangeAt(large))});
  EXPECT_EQ(m.bogus, 1);
  EXPECT_EQ(m.on_other_spool, 0);
  EXPECT_EQ(m.wrong_target.hits, 1);
}

TEST(Scoring, EveryDetectionsDepthIsJudgedAgainstTheSpoolUnderIt)
{
  sv::GroundTruth t = slotSpool(330.0);
  addNeighbour(t, 600.0);
  // A rib ring at 0.6 of the flange taken as the flange: not correct, and its depth (Eq. 3.2 on
  // the smaller circle) is 1/0.6 of the truth, the 40-66% issue 28 reports.
  const sv::FrameScore rib = sv::scoreFrame(t, flangeAt(circleOf(*t.flange, 0.0, -70.0), 0.8 / 0.6));
  EXPECT_FALSE(rib.correct);
  EXPECT_NEAR(rib.any_depth_error, 1.0 / 0.6 - 1.0, 1e-12);
  // The neighbour (82 cm) at its own depth: a wrong target, not a wrong depth.
  const sv::FrameScore neighbour = sv::scoreFrame(t, flangeAt(circleOf(t.neighbours[0].flange), 0.85));
  EXPECT_NEAR(neighbour.any_depth_error, 0.03 / 0.82, 1e-12);
  // Nothing under it: no depth is right.
  sv::Circle off;
  off.x = 30.0;
  off.y = 30.0;
  off.r = 20.0;
  EXPECT_TRUE(std::isinf(sv::scoreFrame(t, flangeAt(off)).any_depth_error));
  // No detection, or no spool in view: not counted.
  const sv::FrameScore none = sv::scoreFrame(t, sv::SpoolDetection{});
  const sv::FrameScore plate = sv::scoreFrame(emptySlot(), flangeAt(off));
  EXPECT_TRUE(std::isnan(none.any_depth_error));

  EXPECT_NEAR(rib.any_height_ratio, 105.0 / 175.0, 1e-12);
  // The joint outline of the front and back flanges, 1.3 times the rim, 23% short.
  const sv::FrameScore outline = sv::scoreFrame(t, flangeAt(circleOf(*t.flange, 0.0, 52.5), 0.8 / 1.3));
  EXPECT_NEAR(outline.any_height_ratio, 1.3, 1e-12);
  // The rim itself at a wrong depth (its pose diverged).
  const sv::FrameScore rim = sv::scoreFrame(t, flangeAt(circleOf(*t.flange, 0.0, 3.0), 0.6));

  const sv::Metrics m = sv::summarize({rib, neighbour, sv::scoreFrame(t, flangeAt(off)), none, plate,
                                       sv::scoreFrame(t, flangeAt(circleOf(*t.flange), 0.87)), outline, rim});
  EXPECT_EQ(m.depth_over_10_percent.frames, 6);
  // the rib ring, the flange on nothing, the outline and the rim at 0.6 m; 8.75% is not
  EXPECT_EQ(m.depth_over_10_percent.hits, 4);
  EXPECT_EQ(m.deep_inside, 1);
  EXPECT_EQ(m.deep_outside, 1);
  EXPECT_EQ(m.deep_same_height, 1);
  EXPECT_EQ(m.deep_on_nothing, 1);
}

TEST(Scoring, WithoutASpoolCentreInViewAnyFlangeIsAFalseSpool)
{
  sv::GroundTruth t = emptySlot();
  addNeighbour(t, 820.0);  // rim partly in view, centre not
  EXPECT_FALSE(sv::targetSpool(t));

  const sv::SpoolDetection on_partial_rim =
      withHole(flangeAt(circleOf(t.neighbours[0].flange)), circleOf(circleAt(820.0, 280.0, 17.0)));
  const sv::FrameScore hit = sv::scoreFrame(t, on_partial_rim);
  const sv::FrameScore quiet = sv::scoreFrame(t, sv::SpoolDetection());
  EXPECT_FALSE(hit.has_target);
  EXPECT_FALSE(hit.flange_eligible);

  const sv::Metrics m = sv::summarize({hit, quiet});
  EXPECT_EQ(m.false_spool.frames, 2);
  EXPECT_EQ(m.false_spool.hits, 1);
  EXPECT_EQ(m.false_hole.frames, 1);
  EXPECT_EQ(m.false_hole.hits, 1);
  EXPECT_EQ(m.flange_found.frames, 0);
  EXPECT_EQ(m.wrong_target.frames, 0);
}

TEST(Scoring, AHoleOffTheBoreIsFalse)
{
  const sv::GroundTruth t = slotSpool(330.0);
  const sv::SpoolDetection d = withHole(flangeAt(circleOf(*t.flange)), circleOf(*t.hole, 6.0));
  const sv::FrameScore s = sv::scoreFrame(t, d);
  EXPECT_TRUE(s.correct);
  EXPECT_FALSE(s.hole_correct);
  const sv::Metrics m = sv::summarize({s});
  EXPECT_EQ(m.hole_found.hits, 0);
  EXPECT_EQ(m.false_hole.hits, 1);
}

TEST(Scoring, NaNDistancesAreLeftOutOfTheErrorStatistics)
{
  const sv::GroundTruth t = slotSpool(330.0);
  const sv::FrameScore measured = sv::scoreFrame(t, flangeAt(circleOf(*t.flange), 0.82, t.yaw));
  const sv::FrameScore undefined = sv::scoreFrame(t, flangeAt(circleOf(*t.flange), kNaN, t.yaw + 0.002));
  EXPECT_TRUE(undefined.correct);
  EXPECT_TRUE(std::isnan(undefined.distance_error));

  const sv::Metrics m = sv::summarize({measured, undefined});
  EXPECT_EQ(m.distance_error.count, 1);
  EXPECT_NEAR(m.distance_error.median, 0.025, 1e-12);
  EXPECT_EQ(m.yaw_error_deg.count, 2);
  EXPECT_NEAR(m.yaw_error_deg.median, 0.001 * 180.0 / M_PI, 1e-9);
}

namespace
{
// The slot's spool at `depth` m in 3D: `lateral` m right of the puller, its axis `axis_angle`
// rad off the optical axis, the puller clearing the bore wall by `clearance` m (negative: it
// touches); aligned when it clears and is in the insertion window.
sv::GroundTruth spoolAt(double depth, double lateral, double axis_angle, double clearance)
{
  sv::GroundTruth t = slotSpool(330.0);
  t.distance = depth;
  t.lateral_offset = lateral;
  t.axis_angle = axis_angle;
  t.puller_clearance = clearance;
  t.puller_clears = clearance >= 0.0;
  t.aligned = t.puller_clears && depth >= 0.5 && depth <= 0.6;
  return t;
}

sv::SpoolDetection measured(const sv::GroundTruth& t, double depth, double lateral, double axis_angle, bool aligned)
{
  sv::SpoolDetection d = flangeAt(circleOf(*t.flange), depth, t.yaw);
  d.lateral_offset = lateral;
  d.axis_angle = axis_angle;
  d.aligned = aligned;
  return d;
}
}  // namespace

TEST(Scoring, PoseErrorsAndAlignmentOnHandMadeFrames)
{
  constexpr double kDeg = M_PI / 180.0;
  // Truth and detection per frame; lateral errors 1, 2, 4 mm inside 50-60 cm, 10 mm at 80 cm
  // (outside the window, not counted); axis-angle errors 0.5, 1, 0.25, 2 deg.
  // a clears the wall by 1 mm, c by 0.1 mm (within a measurement error of it), b touches it.
  const sv::GroundTruth a = spoolAt(0.55, 0.002, 0.2 * kDeg, 0.001);
  const sv::GroundTruth b = spoolAt(0.52, -0.010, 0.5 * kDeg, -0.0075);
  const sv::GroundTruth c = spoolAt(0.60, 0.001, 0.0, 0.0001);
  const sv::GroundTruth d = spoolAt(0.80, 0.0, 1.0 * kDeg, 0.0025);
  std::vector<sv::FrameScore> scores = {
      sv::scoreFrame(a, measured(a, 0.55 * 1.01, 0.003, 0.7 * kDeg, true)),    // aligned, rightly
      sv::scoreFrame(b, measured(b, 0.52, -0.012, -0.5 * kDeg, true)),         // aligned: the puller would touch
      sv::scoreFrame(c, measured(c, 0.60 * 0.98, 0.005, 0.25 * kDeg, false)),  // aligned missed
      sv::scoreFrame(d, measured(d, 0.80, 0.010, 3.0 * kDeg, false)),          // too far: not aligned, right
      sv::scoreFrame(emptySlot(), sv::SpoolDetection())};                      // no spool: puller cannot clear
  EXPECT_NEAR(scores[0].lateral_error, 0.001, 1e-12);
  EXPECT_NEAR(scores[1].axis_angle_error, -1.0 * kDeg, 1e-12);
  EXPECT_NEAR(scores[2].true_depth, 0.60, 1e-12);
  EXPECT_TRUE(scores[0].truth_aligned);
  EXPECT_FALSE(scores[1].truth_puller_clears);

  const sv::Metrics m = sv::summarize(scores);
  EXPECT_EQ(m.lateral_error_mm.count, 3);
  EXPECT_NEAR(m.lateral_error_mm.median, 2.0, 1e-9);
  EXPECT_NEAR(m.lateral_error_mm.p95, 3.8, 1e-9);  // 2 + 0.9 * (4 - 2)
  EXPECT_EQ(m.axis_angle_error_deg.count, 4);
  EXPECT_NEAR(m.axis_angle_error_deg.median, 0.75, 1e-9);
  EXPECT_NEAR(m.axis_angle_error_deg.p95, 1.85, 1e-9);  // 1 + 0.85 * (2 - 1)
  EXPECT_NEAR(m.distance_error.median, 0.005, 1e-9);    // 1%, 0, 2%, 0
  EXPECT_EQ(m.unsafe_aligned.frames, 2);                // b and the empty slot
  EXPECT_EQ(m.unsafe_aligned.hits, 1);
  EXPECT_EQ(m.aligned_recall.frames, 2);  // a and c
  EXPECT_EQ(m.aligned_recall.hits, 1);
  EXPECT_EQ(m.aligned_recall_clear.frames, 1);  // a: c is within kClearRecallSlack of the wall
  EXPECT_EQ(m.aligned_recall_clear.hits, 1);

  // A detector that does not measure the axis yet: counted as frames, no values, "not measured".
  scores[0] = sv::scoreFrame(a, measured(a, 0.55, 0.002, sv::FrameScore::kNaN, true));
  const sv::Metrics unmeasured = sv::summarize({scores[0]});
  EXPECT_EQ(unmeasured.axis_angle_error_deg.count, 0);
  EXPECT_EQ(unmeasured.axis_angle_error_deg.values, 1);
  EXPECT_TRUE(std::isnan(unmeasured.axis_angle_error_deg.p95));
  sv::EvaluationResult r;
  r.config.setups = {{"vga", {640, 480}, {}, sv::QualityBars::forDefault({640, 480}), {}, false}};
  r.config.groups = {{"distorted", {sv::FrameSet::kDistorted}, true}};
  sv::GroupResult group;
  group.metrics = unmeasured;
  r.setups = {{{group}, {}}};
  const std::vector<sv::BarRow> rows = sv::poseRows(r, 0);
  ASSERT_EQ(rows.size(), 11u);
  EXPECT_EQ(rows[7].per_setup[0].measured, "n/a (not measured)");  // axis-angle p95
  EXPECT_TRUE(rows[7].per_setup[0].applies);
  EXPECT_FALSE(rows[7].per_setup[0].pass);
  EXPECT_EQ(rows[3].per_setup[0].measured, "0.00 mm (n = 1)");  // lateral p95
  EXPECT_EQ(rows[8].per_setup[0].measured, "0 of 0");
  EXPECT_FALSE(rows[10].per_setup[0].applies);  // the recall clear of the wall: reported, no bar
}

TEST(Timing, TheSlowestFrameIsTheLeastOfItsRunsAndOnlyCandidatesRunAgain)
{
  // First runs; frame 1 was preempted (its reruns take 1.5 ms), frame 3 is really slow.
  const std::vector<double> first = {1.0, 5.0, 2.0, 4.0, 1.2};
  const std::vector<double> again = {1.0, 1.5, 2.0, 3.5, 1.2};
  std::vector<size_t> rerun;
  const sv::WorstFrame worst = sv::slowestFrame(first,
                                                [&](size_t i)
                                                {
                                                  rerun.push_back(i);
                                                  return again[i];
                                                });
  EXPECT_DOUBLE_EQ(worst.ms, 3.5);
  EXPECT_EQ(worst.index, 3u);
  // Frames 1 and 3, twice each; frame 2's first 2 ms cannot beat 3.5 ms.
  EXPECT_EQ(rerun, (std::vector<size_t>{1, 1, 3, 3}));

  const sv::WorstFrame single = sv::slowestFrame(
      first, [](size_t) -> double { throw std::logic_error("no rerun"); }, 1);
  EXPECT_DOUBLE_EQ(single.ms, 5.0);
  EXPECT_TRUE(std::isnan(sv::slowestFrame({}, [](size_t) { return 0.0; }).ms));
}

TEST(Bars, PerResolutionAsIssues9And28SetThem)
{
  const sv::QualityBars vga = sv::QualityBars::forDefault({640, 480});
  EXPECT_DOUBLE_EQ(vga.flange_found_min, 0.99);
  EXPECT_DOUBLE_EQ(vga.hole_found_min, 0.97);
  EXPECT_DOUBLE_EQ(vga.hole_dark_found_min, 0.90);
  EXPECT_DOUBLE_EQ(vga.false_spool_max, 0.01);
  EXPECT_DOUBLE_EQ(vga.wrong_target_max, 0.01);
  EXPECT_DOUBLE_EQ(vga.depth_over_10_max, 0.0);
  EXPECT_DOUBLE_EQ(vga.distance_median_max, 0.005);
  EXPECT_DOUBLE_EQ(vga.distance_p95_max, 0.015);
  EXPECT_DOUBLE_EQ(vga.yaw_median_max_deg, 0.05);
  EXPECT_DOUBLE_EQ(vga.yaw_p95_max_deg, 0.2);
  EXPECT_DOUBLE_EQ(vga.time_median_max_ms, 2.0);
  EXPECT_DOUBLE_EQ(vga.worst_ratio_max, 3.0);
  EXPECT_TRUE(vga.faster_than_baseline);

  for (cv::Size size : {cv::Size(160, 120), cv::Size(320, 240)})
  {
    const sv::QualityBars small = sv::QualityBars::forDefault(size);
    EXPECT_DOUBLE_EQ(small.flange_found_min, 0.99);
    EXPECT_DOUBLE_EQ(small.hole_found_min, 0.90);
    EXPECT_DOUBLE_EQ(small.false_spool_max, 0.01);
    EXPECT_DOUBLE_EQ(small.wrong_target_max, 0.01);
    EXPECT_DOUBLE_EQ(small.depth_over_10_max, 0.0);
    EXPECT_DOUBLE_EQ(small.worst_ratio_max, 3.0);
    EXPECT_TRUE(small.faster_than_baseline);
    EXPECT_TRUE(std::isnan(small.distance_median_max));
    EXPECT_TRUE(std::isnan(small.yaw_p95_max_deg));
  }
  EXPECT_DOUBLE_EQ(sv::QualityBars::forDefault({160, 120}).hole_dark_found_min, 0.90);
  EXPECT_TRUE(std::isnan(sv::QualityBars::forDefault({320, 240}).hole_dark_found_min));
  EXPECT_DOUBLE_EQ(sv::QualityBars::forDefault({160, 120}).time_median_max_ms, 0.25);
  EXPECT_TRUE(std::isnan(sv::QualityBars::forDefault({320, 240}).time_median_max_ms));

  const sv::QualityBars hd = sv::QualityBars::forDefault({1280, 720});
  EXPECT_DOUBLE_EQ(hd.flange_found_min, 0.99);
  EXPECT_DOUBLE_EQ(hd.hole_found_min, 0.97);
  EXPECT_DOUBLE_EQ(hd.hole_dark_found_min, 0.90);
  EXPECT_DOUBLE_EQ(hd.wrong_target_max, 0.01);
  EXPECT_DOUBLE_EQ(hd.worst_ratio_max, 3.0);
  EXPECT_DOUBLE_EQ(hd.time_median_max_ms, 8.0);
  EXPECT_TRUE(std::isnan(hd.distance_median_max));

  const sv::QualityBars thesis = sv::QualityBars::thesisReproduction();  // as before issue 9
  EXPECT_DOUBLE_EQ(thesis.hole_found_min, 0.90);
  EXPECT_DOUBLE_EQ(thesis.time_median_max_ms, 1.0);
  EXPECT_DOUBLE_EQ(thesis.wrong_target_max, 0.01);
  EXPECT_TRUE(std::isnan(thesis.worst_ratio_max));
  EXPECT_TRUE(std::isnan(thesis.distance_median_max));
}

TEST(Bars, EveryBarThatAppliesMustPassOnEverySet)
{
  sv::EvaluationResult r;
  r.config.setups = {{"thesis", {160, 120}, {}, sv::QualityBars::thesisReproduction(), {}, true},
                     {"qqvga", {160, 120}, {}, sv::QualityBars::forDefault({160, 120}), {}, false},
                     {"vga", {640, 480}, {}, sv::QualityBars::forDefault({640, 480}), {}, true}};
  sv::GroupResult good;
  good.metrics.flange_found = {995, 1000};
  good.metrics.hole_found = {98, 100};
  good.metrics.hole_found_dark = {95, 100};
  good.metrics.false_spool = {0, 100};
  good.metrics.wrong_target = {1, 100};
  good.metrics.distance_error = {0.004, 0.014, 100};
  good.metrics.yaw_error_deg = {0.04, 0.19, 100};
  good.metrics.time_ms = {0.2, 0.22, 1000};
  good.metrics.depth_over_10_percent = {0, 990};
  good.frames = 1000;
  good.baseline_ms = 2.0;
  good.worst = {0.5, 7};
  good.worst_frame = "hard #7";
  good.metrics.lateral_error_mm = {1.0, 4.0, 50, 50};
  good.metrics.axis_angle_error_deg = {0.3, 0.9, 100, 100};
  good.metrics.unsafe_aligned = {0, 900};
  good.metrics.aligned_recall = {48, 50};
  // main + negatives, hard, distorted, oblique, packed, packed oblique
  const sv::SetupResult all_good{{good, good, good, good, good, good}, {}};
  r.setups = {all_good, all_good, all_good};
  auto reset = [&] { r.setups = {all_good, all_good, all_good}; };
  for (size_t s = 0; s < 3; ++s)
    EXPECT_TRUE(sv::barsPass(r, s)) << s;
  EXPECT_EQ(sv::headlineRows(r, 0).size(), 14u);
  EXPECT_EQ(sv::headlineRows(r, 1).size(), 14u);
  EXPECT_EQ(sv::poseRows(r, 2).size(), 11u);

  // Issue 10's pose bars: on the distorted set at 640x480 only.
  r.setups[2].per_group[2].metrics.unsafe_aligned = {1, 900};
  EXPECT_FALSE(sv::barsPass(r, 2));
  r.setups[2].per_group[0].metrics.unsafe_aligned = {1, 900};  // main: reported only
  r.setups[2].per_group[2].metrics.unsafe_aligned = {0, 900};
  EXPECT_TRUE(sv::barsPass(r, 2));
  r.setups[1].per_group[2].metrics.aligned_recall = {0, 50};  // 160x120: reported only
  EXPECT_TRUE(sv::barsPass(r, 1));
  r.setups[2].per_group[2].metrics.aligned_recall = {47, 50};
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();
  r.setups[2].per_group[2].metrics.lateral_error_mm.p95 = 5.1;
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();
  r.setups[2].per_group[2].metrics.axis_angle_error_deg = {sv::FrameScore::kNaN, sv::FrameScore::kNaN, 0, 100};
  EXPECT_FALSE(sv::barsPass(r, 2));  // not measured is not a pass
  const std::string pose = sv::poseTable(r);
  EXPECT_NE(pose.find("n/a (not measured)"), std::string::npos) << pose;
  EXPECT_NE(pose.find("distorted (C270 lens) set"), std::string::npos) << pose;
  reset();

  // Distance and yaw bars are 640x480's only.
  r.setups[1].per_group[0].metrics.distance_error.median = 0.05;
  r.setups[1].per_group[0].metrics.yaw_error_deg.p95 = 2.0;
  EXPECT_TRUE(sv::barsPass(r, 1));
  r.setups[2].per_group[0].metrics.yaw_error_deg.p95 = 0.21;
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();

  // A bar failed on the hard set alone fails the setup.
  r.setups[2].per_group[1].metrics.flange_found = {98, 100};
  EXPECT_FALSE(sv::barsPass(r, 2));
  EXPECT_TRUE(sv::barsPass(r, 1));
  reset();

  // Hole: 90% at 160x120 (lit and dark), 97% lit and 90% dark at 640x480; the thesis' dark bore
  // is reported only.
  for (size_t s = 0; s < 3; ++s)
  {
    r.setups[s].per_group[0].metrics.hole_found = {91, 100};
    r.setups[s].per_group[1].metrics.hole_found_dark = {89, 100};
  }
  EXPECT_TRUE(sv::barsPass(r, 0));
  EXPECT_FALSE(sv::barsPass(r, 1));
  EXPECT_FALSE(sv::barsPass(r, 2));
  for (size_t s = 0; s < 3; ++s)
    r.setups[s].per_group[1].metrics.hole_found_dark = {90, 100};
  EXPECT_TRUE(sv::barsPass(r, 1));
  EXPECT_FALSE(sv::barsPass(r, 2));  // lit 91% is under 640x480's 97%
  r.setups[2].per_group[0].metrics.hole_found = {97, 100};
  EXPECT_TRUE(sv::barsPass(r, 2));
  reset();

  // Issue 28: no depth more than 10% off, on any set, for default.yaml; the thesis reports it.
  for (size_t s = 0; s < 3; ++s)
    r.setups[s].per_group[3].metrics.depth_over_10_percent = {1, 990};
  EXPECT_TRUE(sv::barsPass(r, 0));
  EXPECT_FALSE(sv::barsPass(r, 1));
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();

  // The slowest frame: at most 3x the median for default.yaml, reported only for the thesis.
  for (size_t s = 0; s < 3; ++s)
    r.setups[s].per_group[1].worst.ms = 3.1 * good.metrics.time_ms.median;
  EXPECT_NEAR(r.setups[2].per_group[1].worstRatio(), 3.1, 1e-12);
  EXPECT_TRUE(sv::barsPass(r, 0));
  EXPECT_FALSE(sv::barsPass(r, 1));
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();

  r.setups[2].per_group[0].metrics.wrong_target = {0, 0};  // no frames: not shown to pass
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();

  r.setups[2].per_group[0].baseline_ms = 0.15;  // slower than cv::HoughCircles
  EXPECT_FALSE(sv::barsPass(r, 2));
  reset();
  // Median time: 0.25 ms for default.yaml at 160x120, 1 ms for the thesis, 2 ms at 640x480.
  for (size_t s = 0; s < 3; ++s)
    r.setups[s].per_group[0].metrics.time_ms.median = 0.6;
  EXPECT_TRUE(sv::barsPass(r, 0));
  EXPECT_FALSE(sv::barsPass(r, 1));
  EXPECT_TRUE(sv::barsPass(r, 2));
  for (size_t s = 0; s < 3; ++s)
    r.setups[s].per_group[0].metrics.time_ms.median = 2.1;
  EXPECT_FALSE(sv::barsPass(r, 2));

  // One table per group, a column per setup with its frame count; failures marked.
  const std::string table = sv::headlineTable(r);
  EXPECT_NE(table.find("main + negatives sets"), std::string::npos);
  EXPECT_NE(table.find("hard set"), std::string::npos);
  EXPECT_NE(table.find("vga (1000 frames)"), std::string::npos);
  EXPECT_NE(table.find("**FAIL**"), std::string::npos);
  EXPECT_NE(table.find("hard #7"), std::string::npos);
}

TEST(Baseline, SearchesTheDetectorsRadiusRanges)
{
  const sv::RadiusRanges seed = sv::searchRadii(config("seed.yaml"), sv::CameraIntrinsics::thesisDefault(160, 120));
  EXPECT_DOUBLE_EQ(seed.flange_min, 35.0);
  EXPECT_DOUBLE_EQ(seed.flange_max, 65.0);
  EXPECT_DOUBLE_EQ(seed.hole_min, 3.0);
  EXPECT_DOUBLE_EQ(seed.hole_max, 15.0);
  // Derived from 0.45-1.2 m with f = 800 px.
  const sv::RadiusRanges vga = sv::searchRadii(config("default.yaml"), kVga);
  EXPECT_NEAR(vga.flange_min, 800.0 * 0.175 / 1.2, 1e-9);
  EXPECT_NEAR(vga.flange_max, 800.0 * 0.175 / 0.45, 1e-9);
  EXPECT_NEAR(vga.hole_min, 800.0 * 0.018 / 1.2, 1e-9);
  EXPECT_NEAR(vga.hole_max, 800.0 * 0.018 / 0.45, 1e-9);

  const sv::SpoolRenderer renderer(kVga);
  sv::SceneParams scene;
  const sv::RenderedFrame frame = renderer.render(scene, sv::bearingPose(0.8, 0.0, 0.0, 0.06, 0.0));
  sv::HoughCirclesBaseline baseline(vga);
  baseline.detect(frame.image);
  ASSERT_FALSE(baseline.flanges().empty());
  bool on_flange = false;
  for (const cv::Vec3f& c : baseline.flanges())
    on_flange |= sv::flangeMatches(*frame.truth.flange, sv::Circle{c[0], c[1], c[2], c[2], 1.0, 1.0});
  EXPECT_TRUE(on_flange);
}

TEST(LabelledSets, AreAFunctionOfTheSeedAndCoverTheWorkingRange)
{
  sv::SceneParams a;
  sv::SceneParams b;
  sv::CameraPose pa;
  sv::CameraPose pb;
  sv::setFrame(sv::FrameSet::kMain, 5, 17, 200, a, pa);
  sv::setFrame(sv::FrameSet::kMain, 5, 17, 200, b, pb);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(pa.distance, pb.distance);
  EXPECT_EQ(pa.lateral, pb.lateral);

  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(160, 120));
  int negatives = 0;
  int near = 0;
  int far = 0;
  int left = 0;
  int right = 0;
  for (int i = 0; i < 200; ++i)
  {
    sv::SceneParams scene;
    sv::CameraPose pose;
    sv::setFrame(sv::FrameSet::kMain, 1, i, 200, scene, pose);
    negatives += scene.kind != sv::SceneKind::kSpool ? 1 : 0;
    EXPECT_GE(pose.distance, 0.5);
    EXPECT_LE(pose.distance, 1.1);
    near += pose.distance < 0.6 ? 1 : 0;
    far += pose.distance > 1.0 ? 1 : 0;
    // The slot's bearing (negatives have none).
    const double bearing = renderer.groundTruth(scene, pose).yaw;
    left += bearing < -10.0 * M_PI / 180.0 ? 1 : 0;
    right += bearing > 10.0 * M_PI / 180.0 ? 1 : 0;

    sv::setFrame(sv::FrameSet::kNegatives, 1, i, 200, scene, pose);
    EXPECT_NE(scene.kind, sv::SceneKind::kSpool);
  }
  EXPECT_GT(negatives, 10);  // about 15%
  EXPECT_LT(negatives, 50);
  // Uniform draws: about a sixth of the frames in each distance end, a quarter beyond +-10 deg.
  EXPECT_GT(near, 15);
  EXPECT_GT(far, 15);
  EXPECT_GT(left, 20);
  EXPECT_GT(right, 20);
}

TEST(LabelledSets, TheApproachRunsFrom110To51CmOfDepthAndEndsAligned)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(160, 120));
  std::vector<sv::GroundTruth> truth;
  for (int i = 0; i < 40; ++i)
  {
    sv::SceneParams scene;
    sv::CameraPose pose;
    sv::setFrame(sv::FrameSet::kApproach, 1, i, 40, scene, pose);
    truth.push_back(renderer.groundTruth(scene, pose));
  }
  EXPECT_NEAR(truth.front().distance, 1.10, 0.005);  // the heading error tilts the first view a little
  EXPECT_NEAR(truth.back().distance, 0.51, 1e-9);
  EXPECT_FALSE(truth.front().aligned);
  for (int i = 34; i < 40; ++i)  // inside 60 cm from frame 34 on (frame 33: 60.08 cm)
    EXPECT_TRUE(truth[i].aligned) << i;
  EXPECT_FALSE(truth[33].aligned);
}

TEST(LabelledSets, TheHardApproachTakesTheSamePathAndEndsAlignedOrJustOff)
{
  // Both sides of aligned: over 16 seeds some approaches end aligned and some end with the puller
  // just touching (turned about a degree, or a few mm beside the axis), each with the plain
  // approach's depths, through a webcam with the hard set's imaging and a driving smear.
  const sv::SpoolRenderer renderer(sv::setCamera(sv::FrameSet::kApproachHard, {160, 120}));
  int aligned_endings = 0;
  int touching_endings = 0;
  for (std::uint64_t seed = 1; seed <= 16; ++seed)
  {
    std::vector<sv::GroundTruth> truth;
    sv::SceneParams last_scene;
    for (int i = 0; i < 40; ++i)
    {
      sv::SceneParams scene;
      sv::CameraPose pose;
      sv::setFrame(sv::FrameSet::kApproachHard, seed, i, 40, scene, pose);
      truth.push_back(renderer.groundTruth(scene, pose));
      last_scene = scene;
    }
    EXPECT_NEAR(truth.back().distance, 0.51, 1e-9) << seed;
    EXPECT_GT(last_scene.motion_blur, 0.0);
    EXPECT_TRUE(last_scene.motion_blur_radial);
    EXPECT_GT(last_scene.noise_sigma, 0.0);
    const bool ends_aligned = truth.back().aligned;
    for (int i = 34; i < 40; ++i)  // the whole insertion window ends one way
    {
      EXPECT_EQ(truth[i].aligned, ends_aligned) << seed << " " << i;
      // Just off: the front of the bore is within reach, only the clearance is missed.
      EXPECT_LT(truth[i].puller_miss, 0.005) << seed << " " << i;
    }
    aligned_endings += ends_aligned ? 1 : 0;
    touching_endings += ends_aligned ? 0 : 1;
  }
  EXPECT_GE(aligned_endings, 4);
  EXPECT_GE(touching_endings, 4);
}

TEST(LabelledSets, TheDistortedSetIsMainThroughAC270LensPlusNearAlignedPoses)
{
  const sv::CameraIntrinsics camera = sv::setCamera(sv::FrameSet::kDistorted, {640, 480});
  EXPECT_TRUE(camera.distorted());
  EXPECT_EQ(camera.distortion, sv::c270Distortion());
  EXPECT_DOUBLE_EQ(camera.distortion[0], -0.2);
  EXPECT_DOUBLE_EQ(camera.fx, 800.0);
  EXPECT_NEAR(camera.cx, 319.5 - 6.4, 1e-12);
  EXPECT_NEAR(camera.cy, 239.5 + 3.84, 1e-12);
  EXPECT_FALSE(sv::setCamera(sv::FrameSet::kMain, {640, 480}).distorted());

  const sv::SpoolRenderer renderer(sv::setCamera(sv::FrameSet::kDistorted, {160, 120}));
  int near = 0;
  int clears = 0;
  int aligned = 0;
  for (int i = 0; i < 60; ++i)
  {
    const auto [scene, pose] = drawn(sv::FrameSet::kDistorted, 3, i, 60);
    const DrawnFrame main = drawn(sv::FrameSet::kMain, 3, i, 60);
    if (i % 3 != 2)
    {
      EXPECT_EQ(scene.seed, main.scene.seed) << i;  // main's frame
      EXPECT_EQ(pose.distance, main.pose.distance) << i;
      continue;
    }
    EXPECT_NE(scene.seed, main.scene.seed) << i;
    const sv::GroundTruth truth = renderer.groundTruth(scene, pose);
    ++near;
    EXPECT_GE(truth.distance, 0.48);
    EXPECT_LE(truth.distance, 0.62);
    EXPECT_LT(truth.puller_miss, 0.005);
    clears += truth.puller_clears ? 1 : 0;
    aligned += truth.aligned ? 1 : 0;
  }
  EXPECT_EQ(near, 20);
  EXPECT_GE(clears, 6);  // about 60%, and narrow misses
  EXPECT_LE(clears, 17);
  EXPECT_GE(aligned, 3);

  // Deterministic: the same set renders the same frames.
  const std::vector<sv::RenderedFrame> a = sv::renderSet(renderer, sv::FrameSet::kDistorted, 3, 4);
  const std::vector<sv::RenderedFrame> b = sv::renderSet(renderer, sv::FrameSet::kDistorted, 3, 4);
  ASSERT_EQ(a.size(), 4u);
  for (size_t i = 0; i < a.size(); ++i)
  {
    EXPECT_EQ(cv::norm(a[i].image, b[i].image, cv::NORM_INF), 0.0) << i;
    EXPECT_EQ(sv::groundTruthJson(a[i].truth).dump(), sv::groundTruthJson(b[i].truth).dump()) << i;
    EXPECT_EQ(a[i].truth.camera, renderer.camera());
  }
  // The lens changes the picture of main's frame 0.
  const sv::RenderedFrame pinhole =
      sv::renderSet(sv::SpoolRenderer(sv::setCamera(sv::FrameSet::kMain, {160, 120})), sv::FrameSet::kMain, 3, 1)[0];
  EXPECT_GT(cv::norm(a[0].image, pinhole.image, cv::NORM_L1), 0.0);
}

// Loose bars for small samples: they catch a broken evaluation or a collapsed detector, not
// the §7 bars (those are the report's; see scripts/eval.sh).
TEST(Evaluation, SmallRenderedSetsMeetLooseBars)
{
  const sv::SpoolRenderer small(sv::CameraIntrinsics::thesisDefault(160, 120));
  sv::SpoolDetector thesis(config("seed.yaml"));
  const sv::Metrics m160 = sv::summarize(sv::evaluate(thesis, sv::renderSet(small, sv::FrameSet::kMain, 1, 30)));
  EXPECT_GE(m160.flange_found.frames, 20);
  EXPECT_GE(m160.flange_found.value(), 0.5);
  EXPECT_LE(m160.distance_error.median, 0.05);
  EXPECT_LE(m160.time_ms.median, 50.0);  // a sanity check of the timing field, not a speed bar

  const sv::SpoolRenderer vga(kVga);
  sv::SpoolDetector tuned(config("default.yaml"));
  const sv::Metrics m640 = sv::summarize(sv::evaluate(tuned, sv::renderSet(vga, sv::FrameSet::kMain, 1, 24)));
  EXPECT_GE(m640.flange_found.frames, 15);
  EXPECT_GE(m640.flange_found.value(), 0.7);
  EXPECT_GE(m640.hole_found.value(), 0.7);
  EXPECT_LE(m640.false_hole.value(), 0.1);
  EXPECT_LE(m640.distance_error.median, 0.01);
  EXPECT_LE(m640.yaw_error_deg.median, 0.1);
}

namespace
{
// approach_hard `seed` (40 frames) rendered at `size` and followed by the tracker with default.yaml at 10 Hz.
sv::ApproachTracking trackedHardApproach(cv::Size size, std::uint64_t seed)
{
  const std::vector<sv::RenderedFrame> frames =
      sv::renderSet(sv::SpoolRenderer(sv::setCamera(sv::FrameSet::kApproachHard, size)), sv::FrameSet::kApproachHard,
                    seed, sv::EvaluationConfig::kApproachFrames);
  return sv::trackApproach(config("default.yaml"), frames, sv::EvaluationConfig::kApproachRate, seed);
}
}  // namespace

TEST(Evaluation, AHardApproachFollowedByTheTrackerStaysOnItsSpool)
{
  // approach_hard seed 1001 at 320x240 (40 frames, 10 Hz), default.yaml: published from the
  // third frame (a young track is held), every published frame on the spool, within 3% of its
  // depth, and its 3-sigma ellipsoid holding the truth. A tracker that published another spool
  // or jumped would fail here.
  const sv::ApproachTracking a = trackedHardApproach({320, 240}, 1001);
  EXPECT_EQ(a.frames, 40);
  EXPECT_GE(a.published, 36);
  EXPECT_LE(a.published, 38);  // never the young track's first two frames
  EXPECT_EQ(a.other_spool, 0);
  EXPECT_EQ(a.over_3_percent, 0);
  EXPECT_LT(a.max_depth_error, 0.01);
  EXPECT_GE(a.covariance_holds, a.published - 1);
  EXPECT_EQ(a.aligned_touching, 0);
  EXPECT_EQ(a.windowed_ms.size() + a.full_search_ms.size(), 40u);
  EXPECT_GT(a.windowed_ms.size(), 20u);  // the track searched where it predicts the spool
}

TEST(Evaluation, AHardApproachAt160x120KeepsItsDepthThroughABlurredFrameAndTheCutFlange)
{
  // approach_hard seed 73002 at 160x120. At 81 cm the driving blur gave the tracked rim 3% too
  // large (the moving edges' band took in the edge beside the rim); fused, it turned the velocity,
  // the spool's own rim was refused from then on and taken for a rib ring, and the published depth
  // ran 10-20% short to the end. From 57 cm, with the flange cut by the frame, the same band grew
  // the rim frame after frame (3-8% short). Every published frame within 3% now.
  const sv::ApproachTracking a = trackedHardApproach({160, 120}, 73002);
  EXPECT_GE(a.published, 34);
  EXPECT_EQ(a.other_spool, 0);
  EXPECT_EQ(a.over_3_percent, 0);
  EXPECT_LT(a.max_depth_error, 0.02);
}

TEST(Evaluation, TheReportHoldsEveryTableAndChart)
{
  sv::EvaluationConfig small;
  // Two setups of one size share the renders; the second, without analyses, takes fewer frames.
  small.setups = {{"seed.yaml @ 160x120",
                   {160, 120},
                   config("seed.yaml"),
                   sv::QualityBars::thesisReproduction(),
                   {12, 6, 4, 6, 4, 4, 4},
                   true,
                   false},
                  {"default.yaml @ 160x120",
                   {160, 120},
                   config("default.yaml"),
                   sv::QualityBars::forDefault({160, 120}),
                   {6, 3, 2, 3, 2, 2, 2},
                   false,
                   true}};
  small.pose_repeats = 1;
  small.approaches = 1;
  int progress_calls = 0;
  const sv::EvaluationResult r = sv::runEvaluation(small, [&](const std::string&, int, int) { ++progress_calls; });
  EXPECT_GT(progress_calls, 18);
  ASSERT_EQ(r.setups.size(), 2u);
  // main + negatives, hard, distorted, oblique, packed, packed oblique
  ASSERT_EQ(r.setups[0].per_group.size(), 6u);
  EXPECT_EQ(r.setups[0].per_group[0].frames, 18);
  EXPECT_EQ(r.setups[0].per_group[0].metrics.time_ms.count, 18);
  EXPECT_EQ(r.setups[0].per_group[1].frames, 4);
  EXPECT_EQ(r.setups[0].per_group[2].frames, 6);
  EXPECT_EQ(r.setups[0].per_group[3].frames, 4);
  EXPECT_EQ(r.setups[1].per_group[0].frames, 9);
  EXPECT_EQ(r.setups[1].per_group[1].frames, 2);
  EXPECT_EQ(r.setups[1].per_group[2].frames, 3);
  EXPECT_EQ(r.setups[1].per_group[3].frames, 2);
  EXPECT_EQ(r.setups[0].per_group[4].frames, 4);
  EXPECT_EQ(r.setups[1].per_group[4].frames, 2);
  EXPECT_EQ(r.setups[0].per_group[5].frames, 4);
  EXPECT_EQ(r.setups[1].per_group[5].frames, 2);
  EXPECT_TRUE(r.setups[0].approaches.empty());
  ASSERT_EQ(r.setups[1].approaches.size(), 1u);
  EXPECT_EQ(r.setups[1].approaches[0].frames, sv::EvaluationConfig::kApproachFrames);
  for (const sv::SetupResult& setup : r.setups)
    for (const sv::GroupResult& group : setup.per_group)
    {
      EXPECT_GT(group.baseline_ms, 0.0);
      EXPECT_GT(group.worst.ms, 0.0);
      EXPECT_FALSE(group.worst_frame.empty());
    }
  ASSERT_EQ(r.analyses.size(), 5u);  // filters, binarization, morphology, CHT/MCHT, lamps
  for (const sv::VariantAnalysis& a : r.analyses)
    for (const sv::VariantResult& row : a.rows)
    {
      ASSERT_EQ(row.per_setup.size(), 2u) << a.key << " " << row.label;
      EXPECT_EQ(row.per_setup[1].flange_found.frames, 0) << a.key << " " << row.label;  // no analyses there
    }
  EXPECT_EQ(r.distance_sweep.size(), 7u);
  EXPECT_EQ(r.yaw_sweep.size(), 27u);
  EXPECT_EQ(r.tx_sweep.size(), 18u);
  EXPECT_NEAR(r.yaw_sweep.front().yaw, -20.0 * M_PI / 180.0, 1e-3);
  EXPECT_NEAR(r.distance_sweep.back().distance, std::sqrt(1.1 * 1.1 - 0.06 * 0.06), 1e-9);  // depth at 1.1 m range

  // The variant that is the configuration itself gives the configuration's numbers.
  const sv::Metrics& as_loaded = r.setups[0].per_group[0].metrics;
  const sv::Metrics& mcht = r.analyses[3].rows[0].per_setup[0];
  EXPECT_EQ(mcht.flange_found.hits, as_loaded.flange_found.hits);
  EXPECT_EQ(mcht.false_spool.hits, as_loaded.false_spool.hits);

  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "spool_eval_report";
  std::filesystem::remove_all(dir);
  sv::writeReport(r, dir.string());
  std::ifstream in(dir / "report.md");
  std::stringstream md;
  md << in.rdbuf();
  for (const char* heading :
       {"## Headline", "hard set", "packed (touching neighbours, a back row) set",
        "packed oblique (a packed shelf 25-40 deg off the axis) set", "| packed_oblique frames |",
        "## Pose and alignment", "distorted (C270 lens) set", "-0.2000, 0.0500, 0.0010, -0.0005, 0.0000", "### Filter",
        "### Binarization", "### Morphology", "### CHT vs MCHT", "### Lamp", "### Distance", "### Yaw", "### tx_r",
        "## The tracker over whole approaches", "default.yaml @ 160x120 | 1001"})
    EXPECT_NE(md.str().find(heading), std::string::npos) << heading;
  // The charts' data: one chart per PNG the report shows, its points the tables' numbers.
  const nlohmann::json charts = nlohmann::json::parse(std::ifstream(dir / "charts.json"))["charts"];
  std::map<std::string, nlohmann::json> by_file;
  for (const nlohmann::json& chart : charts)
    by_file[chart["file"]] = chart;
  ASSERT_EQ(by_file.size(), 8u);
  for (const char* png : {"filters", "binarization", "morphology", "cht_mcht", "lamps", "distance", "yaw", "tx_r"})
  {
    ASSERT_EQ(by_file.count(std::string(png) + ".png"), 1u) << png;
    EXPECT_NE(md.str().find(std::string("(") + png + ".png)"), std::string::npos) << png;
  }
  const nlohmann::json& filters = by_file["filters.png"];
  EXPECT_EQ(filters["kind"], "bar");
  ASSERT_EQ(filters["categories"].size(), r.analyses[0].rows.size());
  ASSERT_EQ(filters["groups"].size(), 3u);  // flange found, hole found, false holes of the one analysed setup
  EXPECT_EQ(filters["groups"][0]["label"], "flange found, seed.yaml @ 160x120");
  EXPECT_NEAR(filters["groups"][0]["values"][0].get<double>(),
              100.0 * r.analyses[0].rows[0].per_setup[0].flange_found.value(), 1e-9);
  const nlohmann::json& distance = by_file["distance.png"];
  EXPECT_EQ(distance["kind"], "line");
  ASSERT_EQ(distance["series"].size(), 1u);
  ASSERT_EQ(distance["series"][0]["x"].size(), r.distance_sweep.size());
  for (size_t k = 0; k < r.distance_sweep.size(); ++k)
  {
    const sv::PosePoint& p = r.distance_sweep[k];
    const double error = 100.0 * (p.per_setup[0].distance - p.distance) / p.distance;
    EXPECT_NEAR(distance["series"][0]["x"][k].get<double>(), 100.0 * p.distance, 1e-9);
    if (std::isfinite(error))
      EXPECT_NEAR(distance["series"][0]["y"][k].get<double>(), error, 1e-9) << k;
    else
      EXPECT_TRUE(distance["series"][0]["y"][k].is_null()) << k;  // not measured: a gap
  }
  // A series per distance of the sweep (the depth changes with the yaw; the series does not).
  const nlohmann::json& yaw_series = by_file["yaw.png"]["series"];
  ASSERT_EQ(yaw_series.size(), 3u);
  EXPECT_EQ(yaw_series[0]["label"], "seed.yaml @ 160x120, 100 cm");
  for (const nlohmann::json& series : yaw_series)
    EXPECT_EQ(series["x"].size(), 9u) << series["label"];  // -20 to 20 deg in steps of 5
  EXPECT_EQ(
      by_file["tx_r.png"]["levels"][0]["y"].get<double>(),
      100.0 * 0.5 * (small.setups[0].params.geometry.hole_diameter - small.setups[0].params.geometry.puller_diameter));
}
