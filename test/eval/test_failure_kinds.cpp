// One rendered frame per kind of failure the held-out frames showed (../shared/cases), each at
// the webcam's 640x480, 320x240 and 160x120 with the same default.yaml: the spool in front must
// be found with its bore's front rim. Scenes are built from the hard set's realism on purpose
// (auto exposure, gamma, dark bore, ribs, gloss, the puller rod), not drawn at random.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <string>
#include <tuple>

#include "spool_vision/eval/evaluation.h"

using spool_vision::CameraPose;
using spool_vision::FrameSet;
using spool_vision::GroundTruth;
using spool_vision::PixelFormat;
using spool_vision::RenderedFrame;
using spool_vision::SceneParams;
using spool_vision::SpoolDetection;
using spool_vision::SpoolDetector;
using spool_vision::SpoolRenderer;

namespace
{
constexpr double kDeg = M_PI / 180.0;

// A webcam's look: centre-weighted auto exposure through its gamma, gain noise, MJPEG; ribs off.
SceneParams webcamScene()
{
  SceneParams s;
  s.lamps = spool_vision::LampCondition::kS1S2;
  s.auto_exposure_target = 0.45;
  s.gamma = 0.5;
  s.noise_sigma = 2.5;
  s.jpeg_quality = 75;
  s.ribs = false;
  s.bore_falloff = 0.01;
  s.seed = 7;
  return s;
}

// Frame `index` of `count` of `set` drawn from `seed`, rendered at `width` columns and `height`
// rows (0: 4:3); `detector` gets the set's camera.
RenderedFrame renderSetFrame(FrameSet set, int seed, int index, int count, int width, SpoolDetector& detector,
                             int height = 0)
{
  SceneParams scene;
  CameraPose pose;
  spool_vision::setFrame(set, seed, index, count, scene, pose);
  const SpoolRenderer renderer(spool_vision::setCamera(set, {width, height > 0 ? height : width * 3 / 4}));
  detector.setCamera(renderer.camera());
  return renderer.render(scene, pose);
}

// `frame` (set up for `detector`): the slot's spool is the target, detected, its depth within
// `tolerance` (relative). The detection goes to `detection` where given.
void expectSlotTargetDetected(SpoolDetector& detector, const RenderedFrame& frame, double tolerance,
                              SpoolDetection* detection = nullptr)
{
  const auto target = spool_vision::targetSpool(frame.truth);
  ASSERT_TRUE(target && target->in_slot);
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  if (detection)
    *detection = d;
  ASSERT_TRUE(d.detected);
  EXPECT_TRUE(spool_vision::flangeMatches(target->flange, d.flange))
      << "detected (" << d.flange.x << ", " << d.flange.y << ") r " << d.flange.r << ", target (" << target->flange.x
      << ", " << target->flange.y << ") r " << target->flange.r;
  EXPECT_NEAR(d.distance, frame.truth.distance, tolerance * frame.truth.distance);
}

// `d`'s hole is `frame`'s bore's front rim within the evaluation's tolerance (holeTolerance()).
void expectHoleOnFrontRim(const RenderedFrame& frame, const SpoolDetector& detector, const SpoolDetection& d)
{
  ASSERT_TRUE(frame.truth.hole);
  EXPECT_TRUE(spool_vision::holeMatches(*frame.truth.hole, d.hole, spool_vision::holeTolerance(detector.camera())))
      << "hole (" << d.hole.x << ", " << d.hole.y << ") r " << d.hole.r << ", front rim (" << frame.truth.hole->x
      << ", " << frame.truth.hole->y << ") r " << frame.truth.hole->r;
}

// Frame `index` of `count` of the oblique set from `seed` at `width` columns (720 rows at 1280,
// else 4:3), set up for `detector`; the target is the slot's spool and its bore's front rim is in
// the truth.
RenderedFrame renderObliqueTarget(int seed, int index, int count, int width, SpoolDetector& detector)
{
  RenderedFrame frame =
      renderSetFrame(FrameSet::kOblique, seed, index, count, width, detector, width == 1280 ? 720 : 0);
  const auto target = spool_vision::targetSpool(frame.truth);
  EXPECT_TRUE(target && target->in_slot && frame.truth.hole);
  return frame;
}

std::string obliqueTrace(int seed, int index, int width)
{
  return "oblique seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " + std::to_string(width);
}

// The oblique set's frame `index` of `count` from `seed` at `width` columns: the slot's spool is
// found, its depth within `depth_tolerance` (a fraction) and its axis within `axis_tolerance` (rad).
void expectObliquePose(int seed, int index, int count, int width, double depth_tolerance, double axis_tolerance)
{
  SCOPED_TRACE(obliqueTrace(seed, index, width));
  SpoolDetector detector;
  const RenderedFrame frame = renderObliqueTarget(seed, index, count, width, detector);
  SpoolDetection d;
  expectSlotTargetDetected(detector, frame, depth_tolerance, &d);
  ASSERT_TRUE(d.detected);
  ASSERT_TRUE(std::isfinite(d.axis[2]));
  EXPECT_LT(std::acos(std::clamp(d.axis.dot(frame.truth.axis), -1.0, 1.0)), axis_tolerance)
      << "axis " << d.axis << ", truth " << frame.truth.axis;
}

// The oblique set's frame `index` of `count` from `seed` at `width` columns: the slot's spool is
// found and its hole is its bore's front rim within the evaluation's tolerance.
void expectObliqueHoleOnFrontRim(int seed, int index, int count, int width)
{
  SCOPED_TRACE(obliqueTrace(seed, index, width));
  SpoolDetector detector;
  const RenderedFrame frame = renderObliqueTarget(seed, index, count, width, detector);
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected && d.hole_detected);
  ASSERT_TRUE(spool_vision::flangeMatches(spool_vision::targetSpool(frame.truth)->flange, d.flange));
  expectHoleOnFrontRim(frame, detector, d);
}

// Frame `index` of 200 of `set` from `seed` at `width` columns: the slot's spool is the target,
// found, its depth within 2%.
void expectTargetFound(FrameSet set, int seed, int index, int width)
{
  SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " + std::to_string(width));
  SpoolDetector detector;
  expectSlotTargetDetected(detector, renderSetFrame(set, seed, index, 200, width, detector), 0.02);
}

// Frame `index` of `count` of the oblique set from `seed` at 640x480, its target seen more than
// `min_view` (rad) off its axis: the target's flange found, its depth within 3%.
void expectObliqueTarget(int seed, int index, int count, double min_view)
{
  SCOPED_TRACE("oblique seed " + std::to_string(seed) + " #" + std::to_string(index));
  SpoolDetector detector;
  const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, seed, index, count, 640, detector);
  const auto target = spool_vision::targetSpool(frame.truth);
  ASSERT_TRUE(target);
  ASSERT_GT(target->view_angle, min_view);
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_TRUE(spool_vision::flangeMatches(target->flange, d.flange))
      << "detected (" << d.flange.x << ", " << d.flange.y << ") r " << d.flange.r << ", target (" << target->flange.x
      << ", " << target->flange.y << ") r " << target->flange.r;
  EXPECT_NEAR(d.distance, target->distance, 0.03 * target->distance);
}

// Frame `index` of 200 of the oblique set from `seed` at 640x480: a spool found, its depth within
// `tolerance` (relative) of the slot's spool's.
void expectObliqueDepth(int seed, int index, double tolerance)
{
  SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index));
  SpoolDetector detector;
  const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, seed, index, 200, 640, detector);
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_NEAR(d.distance, frame.truth.distance, tolerance * frame.truth.distance);
}

struct Case
{
  SceneParams scene;
  CameraPose pose;
};

// The target seen `view` rad off its axis (the camera beside the axis, turned to look at it) at
// `distance` m.
Case at(const SceneParams& scene, double distance, double view)
{
  return {scene, spool_vision::bearingPose(distance, 0.0, view, 0.06, 0.0)};
}

void expectFrontRim(const Case& c, int width)
{
  const cv::Size size(width, width * 3 / 4);
  const SpoolRenderer renderer(spool_vision::setCamera(FrameSet::kHard, size));
  const RenderedFrame frame = renderer.render(c.scene, c.pose);
  const GroundTruth& t = frame.truth;
  ASSERT_TRUE(t.flange && t.hole && t.hole_in_view);
  SpoolDetector detector;
  detector.setCamera(renderer.camera());
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  SCOPED_TRACE("at " + std::to_string(width) + " columns");
  ASSERT_TRUE(d.detected);
  EXPECT_TRUE(spool_vision::flangeMatches(*t.flange, d.flange));
  ASSERT_TRUE(d.hole_detected);
  // DESIGN.md §7: the front rim within 1 px at 640x480; a few-pixel bore to a tenth of its size.
  const double tol = width >= 640 ? 1.0 : std::max(1.0, 0.1 * t.hole->r);
  EXPECT_LE(std::hypot(d.hole.x - t.hole->x, d.hole.y - t.hole->y), tol);
  EXPECT_NEAR(d.hole.r, t.hole->r, tol);
}

void expectAtEveryResolution(const Case& c)
{
  for (const int width : {640, 320, 160})
    expectFrontRim(c, width);
}
}  // namespace

// pos_124, pos_239: 12 deg off its axis the bore is a dark disc in a mid-grey face.
TEST(FailureKinds, DarkBoreInAnAutoExposedFace)
{
  const Case c = at(webcamScene(), 0.7, 12 * kDeg);
  ASSERT_FALSE(
      SpoolRenderer(spool_vision::setCamera(FrameSet::kHard, {640, 480})).groundTruth(c.scene, c.pose).bore_visible);
  expectAtEveryResolution(c);
}

// Far off the principal point the bore wall near the opening, lit like the face, shows inside the
// rim on the side away from it: a free fit of the dark region comes out small and off centre.
TEST(FailureKinds, DarkBoreWithItsLitWallBandFarFromTheImageCentre)
{
  SceneParams s = webcamScene();
  s.bore_falloff = 0.015;
  expectAtEveryResolution({s, spool_vision::bearingPose(0.6, 12 * kDeg, 0.0, 0.06, 0.0)});
}

// pos_031, pos_167: near the axis only a parallax lens of the bore is lit; the rim is around it.
TEST(FailureKinds, SeeThroughLensInsideTheFrontRim)
{
  const Case c = at(webcamScene(), 0.95, 1 * kDeg);
  const GroundTruth t =
      SpoolRenderer(spool_vision::setCamera(FrameSet::kHard, {640, 480})).groundTruth(c.scene, c.pose);
  ASSERT_TRUE(t.bore_visible);
  ASSERT_LT(t.hole_lit_fraction, 0.9);
  expectAtEveryResolution(c);
}

// pos_032, pos_096: raised ribs on the face at about 1 m, lit bore.
TEST(FailureKinds, RibbedFaceAtOneMetre)
{
  SceneParams s = webcamScene();
  s.ribs = true;
  s.rib_slope = 0.7;
  expectAtEveryResolution(at(s, 1.05, 2 * kDeg));
}

// A strong lamp's specular streak across a glossy face.
TEST(FailureKinds, SpecularStreakOnAGlossyFace)
{
  SceneParams s = webcamScene();
  s.gloss = 0.5;
  expectAtEveryResolution(at(s, 0.85, 6 * kDeg));
}

// The puller rod in view at the bottom of the frame, motion blur along the approach.
TEST(FailureKinds, PullerRodAndMotionBlurOnTheApproach)
{
  SceneParams s = webcamScene();
  s.puller_rod_length = 0.2;
  s.motion_blur = 3.0;
  s.motion_blur_radial = true;
  expectAtEveryResolution(at(s, 0.75, 3 * kDeg));
}

// False spools of the main and negatives sets at the small sizes (tuning seeds): a plate, or a
// neighbour whose face centre is just out of view, taken as a flange with a faint ring of the
// bore's size inside it. No spool's centre is in view, so the answer is no spool; with every weak
// ring counting (weak_hole_score 0) each frame was reported as one.
TEST(FailureKinds, FaintRingWithoutABoreDiscIsNoHole)
{
  struct Frame
  {
    FrameSet set;
    const char* name;
    int index;
    int count;
    int width;
  };
  for (const Frame& f :
       {Frame{FrameSet::kNegatives, "negatives", 14, 150, 160}, Frame{FrameSet::kMain, "main", 34, 300, 160},
        Frame{FrameSet::kNegatives, "negatives", 6, 100, 320}})
  {
    SCOPED_TRACE(std::string(f.name) + " #" + std::to_string(f.index) + " at " + std::to_string(f.width) + " columns");
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(f.set, 11, f.index, f.count, f.width, detector);
    ASSERT_FALSE(frame.truth.spool_centre_in_view);
    EXPECT_FALSE(detector.detect(frame.image, PixelFormat::kBgr8).detected);
    spool_vision::DetectorParams every_ring;
    every_ring.matcher.weak_hole_score = 0.0;
    every_ring.matcher.cut_flange_hole_score = 0.0;
    detector.setParams(every_ring);
    EXPECT_TRUE(detector.detect(frame.image, PixelFormat::kBgr8).detected);
  }
}

// False spools of the negatives set at 160x120 (tuning seeds 16 and 19): a neighbour whose face
// centre is just out of view, its back flange or joint silhouette fitted as a flange with about
// 60% of its rim in the frame and centred on its face, where rib arcs (seed 16) or a label's
// corner (seed 19) close a hole-sized ring scoring 0.59-0.64 whose disc does not show.
TEST(FailureKinds, AWeakRingOnAFlangeCutByTheBorderIsNoHole)
{
  for (const auto& [seed, index] : {std::pair{16, 55}, std::pair{16, 169}, std::pair{19, 35}})
  {
    SCOPED_TRACE("negatives seed " + std::to_string(seed) + " #" + std::to_string(index));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(FrameSet::kNegatives, seed, index, 200, 160, detector);
    ASSERT_FALSE(frame.truth.spool_centre_in_view);
    EXPECT_FALSE(detector.detect(frame.image, PixelFormat::kBgr8).detected);
    spool_vision::DetectorParams uncut;
    uncut.matcher.cut_flange_hole_score = 0.0;
    detector.setParams(uncut);
    const SpoolDetection found = detector.detect(frame.image, PixelFormat::kBgr8);
    EXPECT_TRUE(found.detected);
    EXPECT_LT(found.flange.visible_fraction, 0.7);
  }
}

namespace
{
// Frame `index` of `count` of `set` (seed `seed`) at `width` columns: the detector's flange is
// the target's.
void expectTargetFlange(int seed, int index, int count, FrameSet set = FrameSet::kHard, int width = 640, int height = 0)
{
  SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " + std::to_string(width) +
               " columns");
  SpoolDetector detector;
  const RenderedFrame frame = renderSetFrame(set, seed, index, count, width, detector, height);
  const auto target = spool_vision::targetSpool(frame.truth);
  ASSERT_TRUE(target);
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_TRUE(spool_vision::flangeMatches(target->flange, d.flange))
      << "detected (" << d.flange.x << ", " << d.flange.y << ") r " << d.flange.r << ", target (" << target->flange.x
      << ", " << target->flange.y << ") r " << target->flange.r;
}
}  // namespace

// A glossy face under a lamp, lighter than the shelf: the spool right in front (1.5 deg off)
// was no dark-rim candidate, and a dark neighbour 20 deg off was reported (flange_retry).
TEST(FailureKinds, ALighterFaceInFrontIsNotPassedOverForADarkNeighbour)
{
  expectTargetFlange(13, 124, 200);
}

// A concentric rib fitted as a second candidate, inside the rim: the rim measured about the
// bore replaces it (it scores better and is larger by more than the concentric tolerance).
TEST(FailureKinds, ARibFittedInsideTheRimGivesWayToTheRimAboutTheBore)
{
  expectTargetFlange(12, 190, 200);
}

// At 160x120 a rim cut by the frame border was fitted 3-4 px off its bore, and the rim measured
// about the bore scored as well (both fully supported, 1.0): on that tie too the rim about the
// bore replaces the fit.
TEST(FailureKinds, ARimFitOffItsBoreGivesWayToTheRimAboutTheBoreOnATie)
{
  expectTargetFlange(15, 17, 200, FrameSet::kHard, 160);
  expectTargetFlange(11, 47, 200, FrameSet::kNegatives, 160);
}

// Spools seen 25-40 deg off their axis (oblique set, tuning seed 21, with the wall prints): the
// flange is an ellipse 0.77-0.9 as wide as high beside its back flange's silhouette. No circle of
// the Hough search had its bore at the centre (51, 66: no spool), or the one taken ran along the
// back flange (28: its centre 17 px off); the rim found about the bore over turned poses is the
// flange.
TEST(FailureKinds, AFlangeSeenFarOffItsAxisIsFoundAboutItsBore)
{
  for (const int index : {28, 51, 66})
    expectTargetFlange(21, index, 120, FrameSet::kOblique);
}

// A rib ring at 0.86 of the rim taken as the flange on the hard set with wall prints (tuning seed
// 7 at 640x480; depth 18-51% off): #154 (88 cm) measured its hole at the bore's true size, 15%
// over what the ring allows; on #10 (51 cm, 70% of the rim in view) the hole taken was the lit
// lens inside the bore, which the bore's rim at its own size holds and ties with, and the first
// rim found above the ring was the next rib, with the flange above it.
TEST(FailureKinds, ARibRingNearTheRimGivesWayToTheRimItsBoreAgreesWith)
{
  for (const int index : {10, 154})
    expectTargetFlange(7, index, 200);
}

// A lamp's highlight across a glossy face cut by the frame (hard seed 7 #162 at 640x480): the rim
// fit from the Hough cell followed the highlight's edges beside the rim (0.66 m for 0.71 m) and
// its hole search found a weak ring off the bore; the rim fitted again on the circle the most
// edges support nearby has the bore (SpoolDetector::refitWeakMatch).
TEST(FailureKinds, ARimFitPulledOffItsRimIsFittedAgainWhereItsBoreIs)
{
  expectTargetFlange(7, 162, 200);
}

// Texture elsewhere in the frame takes a clear target's rim edges out of the edge budget (wall
// prints and a carton mural: hard seed 7 #56 at 640x480, hard seed 11 #98 at 160x120, nothing was
// found): the frame searched again with twice the budget finds the target, taken as both its rims
// are solid (SpoolDetector::kRetryBudgetScale).
TEST(FailureKinds, TextureElsewhereDoesNotStarveAClearTargetOfItsEdges)
{
  expectTargetFlange(7, 56, 200);
  expectTargetFlange(11, 98, 200, FrameSet::kHard, 160);
}

// Circles joining two spools seen 25-40 deg off their axes, each with a faint "hole" ring about a
// patch lighter than the face around it (copper, a label, the light between the spools): reported
// 26-51% off in depth (oblique seed 7 #0, #110, #199 at 640x480). From 6 px of radius up, a hole
// rim under weak_hole_score counts only about a darker disc; where that leaves the circle without
// a hole, #16 and #79 find their targets instead.
TEST(FailureKinds, AFaintRingAboutALighterPatchIsNoBore)
{
  for (const int index : {0, 110, 199})
  {
    SCOPED_TRACE("oblique seed 7 #" + std::to_string(index));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, 7, index, 200, 640, detector);
    const spool_vision::FrameScore score =
        spool_vision::scoreFrame(frame.truth, detector.detect(frame.image, PixelFormat::kBgr8));
    // No detection, or one within 10% of the depth of the spool it lies on.
    EXPECT_FALSE(std::abs(score.any_depth_error) > spool_vision::kAbsurdDepthError) << score.any_depth_error;
  }
  expectTargetFlange(7, 16, 200, FrameSet::kOblique);
  expectTargetFlange(7, 79, 200, FrameSet::kOblique);
}

// A weak rim in front, a solid one beside it: the spool nearest the reference has a grey or
// glossy face on a wall as light, or a back row behind its touching neighbours, and scores under
// the least rim support, so a spool 10-20 deg off was reported (packed seed 7 #124 at 640x480 and
// seed 13 #124 at 160x120, hard seed 7 #135 at 160x120, oblique seed 11 #91 at 640x480). The search
// for a spool nearer the reference with less rim support asked finds it
// (SpoolDetector::searchNearer()). The ghosts that search admits need a hole rim of
// kNearerHoleScore (a 0.37 ring made one 0.44 m deep on hard seed 7 #69, a negative) and their
// whole rim in view (board and neighbour arcs cut by the border closed a 0.31 circle about a wall
// mark on packed seed 13 #19, a negative).
TEST(FailureKinds, AWeakRimInFrontIsNotPassedOverForASolidOneFartherOff)
{
  expectTargetFlange(7, 124, 200, FrameSet::kPacked);
  expectTargetFlange(13, 124, 200, FrameSet::kPacked, 160);
  expectTargetFlange(7, 135, 200, FrameSet::kHard, 160);
  expectTargetFlange(11, 91, 200, FrameSet::kOblique);
  // The nearer spool's weak circle was the joint silhouette of its two flanges (3.5% short in
  // depth); the either-polarity search, run after it too, finds its front rim.
  expectTargetFlange(13, 191, 200, FrameSet::kOblique);
  for (const auto& [set, seed, index] : {std::tuple{FrameSet::kHard, 7, 69}, std::tuple{FrameSet::kPacked, 13, 19}})
  {
    SCOPED_TRACE(std::string(spool_vision::toString(set)) + " seed " + std::to_string(seed) + " #" +
                 std::to_string(index));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(set, seed, index, 200, 640, detector);
    const spool_vision::FrameScore score =
        spool_vision::scoreFrame(frame.truth, detector.detect(frame.image, PixelFormat::kBgr8));
    // No detection, or one within 10% of the depth of the spool it lies on.
    EXPECT_FALSE(std::abs(score.any_depth_error) > spool_vision::kAbsurdDepthError) << score.any_depth_error;
  }
}

// Seen 28-40 deg off its axis, a dark bore shows part of its opening dark, so its circle sits 3-6 px
// off the bore's centre, and the rim fitted about that ray kept too few edges in its band: the
// oblique search found nothing (seed 7 #68), or an inner ring 17% deep (seed 13 #128). And the
// right rim, its back flange's silhouette beside it, kept 0.57-0.6 of its samples, under the 0.75
// asked (seed 7 #42, #56). And the dark part of the opening narrows with the view's cosine: its
// circle came out under 0.8 of the size the rim gives it, and the rim was refused (seed 11 #57,
// seed 13 #133). Each is found, its depth within 2%.
TEST(FailureKinds, AnObliqueRimIsFoundAboutADarkBoreMeasuredOffItsCentre)
{
  for (const auto& [seed, index] : {std::pair{7, 68}, std::pair{13, 128}, std::pair{7, 42}, std::pair{7, 56},
                                    std::pair{11, 57}, std::pair{13, 133}})
    expectTargetFound(FrameSet::kOblique, seed, index, 640);
}

// A circle around an oblique rim and its back flange's silhouette, 12-30% too large, with the hole
// measured at the size it gives (too large as well, 5 px off): no pose about that hole fitted, and
// the depth was 11-13% short (oblique seed 7 #5, seed 11 #68, seed 13 #53). The bore measured
// again at smaller sizes gives the rim, its depth within 2%.
TEST(FailureKinds, AnObliqueRimsJointSilhouetteGivesWayToTheRimAboutItsOwnBore)
{
  for (const auto& [seed, index] : {std::pair{7, 5}, std::pair{11, 68}, std::pair{13, 53}})
    expectObliqueDepth(seed, index, 0.02);
}

// Textured frames whose edges filled the budget gave no spool, and the search with twice the budget
// found the target about a sharp, whole bore rim (1.0), its flange scoring 0.65-0.77 (cut by the
// frame, or half hidden by its back flange's silhouette): under the 0.8 asked of both rims, it was
// dropped (hard seed 11 #188, seed 13 #85; oblique seed 7 #107, seed 13 #192). Each is found, its
// depth within 2%.
TEST(FailureKinds, TheSecondSearchTakesASpoolAboutASharpWholeBore)
{
  for (const auto& [set, seed, index] :
       {std::tuple{FrameSet::kHard, 11, 188}, std::tuple{FrameSet::kHard, 13, 85},
        std::tuple{FrameSet::kOblique, 7, 107}, std::tuple{FrameSet::kOblique, 13, 192}})
    expectTargetFound(set, seed, index, 640);
}

// No flange circle led to the spool: none was among those searched, or the Hough circle lay more
// than a third of its size off the bore (hard seed 13 #36 at 160x120; oblique seed 7 #26, #160,
// seed 11 #62, seed 13 #130 at 640x480, 26-31 deg off their axes). The sharp dark bore nearest the
// reference leads to the rim. Each is found, its depth within 2%.
TEST(FailureKinds, TheBoreNearestThePullerLeadsToARimNoFlangeCircleFound)
{
  for (const auto& [set, seed, index, width] :
       {std::tuple{FrameSet::kHard, 13, 36, 160}, std::tuple{FrameSet::kOblique, 7, 26, 640},
        std::tuple{FrameSet::kOblique, 7, 160, 640}, std::tuple{FrameSet::kOblique, 11, 62, 640},
        std::tuple{FrameSet::kOblique, 13, 130, 640}})
    expectTargetFound(set, seed, index, width);
}

// Seen 20-50 deg off its axis, the bore's wall near the opening, lit like the face, shows inside
// the rim on the side away from the axis's vanishing point, and the hole was measured 3-9 px off
// its front rim (oblique seed 7 #81, seed 11 #98, seed 13 #44 at 640x480; seed 7 #73 at 320x240),
// the wall's side taken from the principal point. Measured again on the side the spool's axis
// gives, each hole is its front rim within the evaluation's tolerance.
TEST(FailureKinds, AnObliqueBoresLitWallIsOnTheSideItsAxisGives)
{
  for (const auto& [seed, index, width] :
       {std::tuple{7, 81, 640}, std::tuple{11, 98, 640}, std::tuple{13, 44, 640}, std::tuple{7, 73, 320}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " + std::to_string(width));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, seed, index, 200, width, detector);
    ASSERT_TRUE(frame.truth.hole);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    ASSERT_TRUE(d.detected && d.hole_detected);
    expectHoleOnFrontRim(frame, detector, d);
  }
}

// Seen 30-38 deg off its axis, a spool's flange ellipse measures 3-6% tall while its rim's 3-D pose
// gives the depth within 1-2%: its dark bore, measured at the size the flange's ellipse gives it,
// came out 1.1-1.9 px large and 1-2 px off its front rim (oblique seed 19 #12, seed 89 #99 of 100,
// seed 131 #115 of 150 at 640x480; seed 47 #19 of 50 at 1280x720). Measured at the size the pose
// gives it (the 3.6 cm circle projected), each hole is its front rim within the evaluation's tolerance.
TEST(FailureKinds, AnObliqueBoreIsMeasuredAtTheSizeItsRimsPoseGivesIt)
{
  for (const auto& [seed, index, count, width] : {std::tuple{19, 12, 100, 640}, std::tuple{89, 99, 100, 640},
                                                  std::tuple{131, 115, 150, 640}, std::tuple{47, 19, 50, 1280}})
    expectObliqueHoleOnFrontRim(seed, index, count, width);
}

// Seen 33-38 deg off its axis, a flange whose ellipse gave no plausible pose (the conic's solution
// diverged or contradicted Eq. 3.2) was published with no axis and Eq. 3.2's depth on an ellipse
// 3-8% tall or short (oblique seed 97 #18, seed 43 #79 of 100 at 640x480, seed 131 #42 of 60 at
// 1280x720, seed 97 #82 of 100 at 320x240). Fitted on its rim from the axes the ellipse's aspect
// allows, the pose is the rim's: the depth within 1%, the axis within 4 deg.
TEST(FailureKinds, AnObliqueRimsPoseIsFittedFromItsAspectWhereItsEllipseGaveNone)
{
  for (const auto& [seed, index, count, width] : {std::tuple{97, 18, 100, 640}, std::tuple{43, 79, 100, 640},
                                                  std::tuple{131, 42, 60, 1280}, std::tuple{97, 82, 100, 320}})
    expectObliquePose(seed, index, count, width, 0.01, 4.0 * kDeg);
}

// A rib ring taken as the flange of a spool seen 20-45 deg off its axis (oblique seed 7 #11, seed
// 13 #73 at 640x480: depth 17-21% long). Its bore, measured at its own size with the lit wall on
// the side the axis gives, is 1.12-1.28 times what the ring allows; the rim outside the ring that
// agrees with it is the flange, its depth within 3%.
TEST(FailureKinds, AnObliqueRibRingGivesWayToTheRimItsBoreMeasuresOutside)
{
  for (const auto& [seed, index] : {std::pair{7, 11}, std::pair{13, 73}})
    expectObliqueDepth(seed, index, 0.03);
}

// A large rim seen far off its axis and cut by the frame kept under 48 of its 96 moving-edge
// samples in view, too few to judge its own pose's fit, so the circle the Hough search gave stood:
// the joint silhouette of its two flanges (oblique seed 7 #70, #138 at 640x480, 14-22% too large)
// or a circle 10% small (seed 11 #24 at 320x240). Sampled as densely in view as a whole rim, the
// fit fails and the rim about the bore is found.
TEST(FailureKinds, ACutObliqueRimIsSampledAsDenselyAsAWholeOne)
{
  for (const auto& [seed, index, width] : {std::tuple{7, 70, 640}, std::tuple{7, 138, 640}, std::tuple{11, 24, 320}})
    expectTargetFound(FrameSet::kOblique, seed, index, width);
}

// A rim found about a sharp dark bore but supported on under 0.55 of its samples (a glossy band,
// labels and the puller rod over a grey face on a dark shelf: hard seed 7 #160, 0.54, the spool
// in front 3 deg off the puller; oblique seed 7 #140, seed 13 #156) was no spool, and nothing was
// reported. Where the bore, measured at its own size, agrees with the rim within 6% (a rib ring's
// bore measures 1.1-1.3 of what the ring allows, a joint silhouette's under 0.92), a rim on 0.3
// of its samples is the spool. Each is found, its depth within 2%.
TEST(FailureKinds, AWeakRimAboutASharpBoreIsTheSpoolWhereTheBoresOwnSizeAgrees)
{
  for (const auto& [set, seed, index] : {std::tuple{FrameSet::kHard, 7, 160}, std::tuple{FrameSet::kOblique, 7, 140},
                                         std::tuple{FrameSet::kOblique, 13, 156}})
    expectTargetFound(set, seed, index, 640);
}

// The target's Hough circle was the weak one (0.32) searchNearer() found: 8% too large and 26 px
// above its bore, whose lit lens splits its rim, so no bore lay in its concentric window, and a
// neighbour 25 deg off was reported (hard seed 7 #160 at 1280x720). Seen 36-38 deg off its axis,
// the slot's spool gave only such a circle, and a neighbour 15-19 deg off was reported 21-22%
// nearer (oblique seed 13 #170, #172). The bore within a third of that circle's size leads to
// the rim.
TEST(FailureKinds, AWeakCircleNearerThePullerLeadsToTheBoreBesideIt)
{
  expectTargetFlange(7, 160, 200, FrameSet::kHard, 1280, 720);
  expectTargetFlange(13, 170, 200, FrameSet::kOblique);
  expectTargetFlange(13, 172, 200, FrameSet::kOblique);
}

// Two spools about sharp bores, 11 and 12 deg off the puller: the nearer one's grey face with a
// glossy band on a dark shelf supports 0.49-0.57 of its rim, the other's 0.73-0.8, and the rim
// weighting handed the target to the farther one (hard seed 7 #40 at 1280x720; hard seed 11 #68
// at 640x480, 15 deg off against 17, its rim at 0.66 against 0.99). About a sharp bore the rim's support weighs less
// (SpoolDetector::bearingSupport()).
TEST(FailureKinds, ASpoolAboutASharpBoreIsNotPassedOverForASolidRimFartherOff)
{
  expectTargetFlange(7, 40, 200, FrameSet::kHard, 1280, 720);
  expectTargetFlange(11, 68, 200, FrameSet::kHard);
}

// Near the axis at 320x240, a bore whose lit lens fills most of it measured 4-5% large at its own
// size, or a circle 9 px off the hole took its place: the whole, sharp flange (0.8-1.0) was taken
// for a rib ring and a faint circle 15-80% larger outside it reported, 13-44% short (hard seed 19
// #48, #121, #147; seed 23 #102). The bore at its own size must be about as near the flange's
// centre as the hole, and a rim whole in the frame outside a near-axis flange needs the frame's
// own support.
TEST(FailureKinds, ASharpWholeRimAboutALitLensIsNotTakenForARibRing)
{
  for (const auto& [seed, index] : {std::pair{19, 48}, std::pair{19, 121}, std::pair{19, 147}, std::pair{23, 102}})
    expectTargetFound(FrameSet::kHard, seed, index, 320);
}

// A face at 0.51 m overfilling a 160x120 frame, its bore's lens lit: the only circle about the
// bore was a rib ring at 0.65 of the rim, whose bore (1.0 of its rim, 1.5 times what the ring
// allows it) the match refuses, and nothing was reported (hard seed 7 #10). A circle about a sharp
// bore too large for it is a rib ring: the flange outside it is found, its depth within 2%.
TEST(FailureKinds, ARibRingAboutABoreTooLargeForItLeadsToTheFlange)
{
  expectTargetFound(FrameSet::kHard, 7, 10, 160);
}

// Looking along a row of spools turned 30-40 deg from the line of sight, the one nearest the
// puller can be seen 45-60 deg off its axis: its flange an ellipse half as wide as high, its bore a
// dark slit. The Hough search's circles missed both, and a neighbour 7-20 deg farther off the
// puller was reported (oblique seed 7 #1, #63, #116; seed 11 #17; seed 19 #23 at 640x480). Its
// bore, searched about the reported spool's axis, leads to it: found, its depth within 3%. Seed 19
// #57: the reported spool's pose gave no axis; its flange's ellipse gives two, and one leads there.
TEST(FailureKinds, ASpoolSeenFarOffItsAxisNearerThePullerIsNotPassedOverForItsNeighbour)
{
  for (const auto& [seed, index] :
       {std::pair{7, 1}, std::pair{7, 63}, std::pair{7, 116}, std::pair{11, 17}, std::pair{19, 23}, std::pair{19, 57}})
    expectObliqueTarget(seed, index, 200, 45.0 * kDeg);
}

// At the start of an approach (1.0-1.1 m) a light ribbed face shaded across, its bore seen
// through with the far end's light a lens over a third of it: no flange circle in either polarity,
// and the whole disc's mean lies between the face's on either side, so the bore-led search passed
// over its sharp rim, and a neighbour was reported (and tracked for 11-21 frames: approach_hard
// seed 84 at 640x480 and 1280x720, 73002 at 1280x720). Its darker half darker and its lit part
// brighter than the face all round, it leads to the target: found, its depth within 2%.
TEST(FailureKinds, ABoreSeenThroughOnAFaceShadedAcrossLeadsToTheTarget)
{
  for (const auto& [seed, index, width] : {std::tuple{84, 3, 640}, std::tuple{84, 6, 1280}, std::tuple{73002, 5, 1280}})
  {
    SCOPED_TRACE("approach_hard seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " +
                 std::to_string(width));
    SpoolDetector detector;
    expectSlotTargetDetected(
        detector, renderSetFrame(FrameSet::kApproachHard, seed, index, 40, width, detector, width == 1280 ? 720 : 0),
        0.02);
  }
}

// Seen 35-40 deg off its axis, a dark bore was measured at its known size on the flange's Hough
// circle, round, before the flange's pose measured the rim as an ellipse 0.78 as wide as high;
// where that pose gave no axis nothing measured the bore again, and the round fit slid 3-5 px off
// the bore's centre, 15-20% large (oblique seed 7 #74 and seed 19 #1 of 100 at 640x480, seed 19
// #31 of 50 at 1280x720). Measured again on the flange's ellipse scaled, the bore's front rim is
// found within a pixel (1.5 px at 1280x720: holeTolerance()).
TEST(FailureKinds, ADarkBoreInAnOvalFlangeIsMeasuredAsAnOval)
{
  for (const auto& [seed, index, count, width] :
       {std::tuple{7, 74, 100, 640}, std::tuple{19, 1, 100, 640}, std::tuple{19, 31, 50, 1280}})
  {
    SCOPED_TRACE(obliqueTrace(seed, index, width));
    SpoolDetector detector;
    const RenderedFrame frame = renderObliqueTarget(seed, index, count, width, detector);
    ASSERT_FALSE(frame.truth.bore_visible);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    ASSERT_TRUE(d.detected && d.hole_detected);
    ASSERT_TRUE(spool_vision::flangeMatches(spool_vision::targetSpool(frame.truth)->flange, d.flange));
    EXPECT_LT(d.hole.r_horizontal, SpoolDetector::kNearAxisAspect * d.hole.r_vertical);
    expectHoleOnFrontRim(frame, detector, d);
  }
}

// Seen 25-35 deg off its axis and 50-100 px above or below the axis's vanishing point, a dark
// bore's front rim is an ellipse tilted 5-12 deg from upright. Measured on the upright ellipse of
// its size and aspect, fitted on the sharp half facing the vanishing point, it came out 1.2-1.5 px
// off centre (oblique seed 131 #8 of 150, seed 97 #22 and seed 7 #12 of 100 at 640x480; seed 131
// #39 of 60 at 1280x720): outside the evaluation's 1 px (1.5 px at 1280x720).
// On the projected, tilted ellipse of a level spool's bore it is found within it.
TEST(FailureKinds, ADarkBoreOffItsVanishingPointsRowIsMeasuredOnItsTiltedEllipse)
{
  for (const auto& [seed, index, count, width] : {std::tuple{131, 8, 150, 640}, std::tuple{97, 22, 100, 640},
                                                  std::tuple{7, 12, 100, 640}, std::tuple{131, 39, 60, 1280}})
    expectObliqueHoleOnFrontRim(seed, index, count, width);
}

// A bore whose spool's pose puts its axis within 10 deg of the optical axis was reported as measured
// about its hole circle at the flange circle's shape: on a lit lens near the axis or at the frame's
// edge (hard seed 7 #1, #56 of 100) and, seen 14 deg off by a pose 6 deg short, round on a round
// flange circle (oblique seed 131 #70 of 150), 1.1-1.2 px off, at 640x480. Measured again at the
// size and shape the pose projects it to, each is its front rim within the evaluation's 1 px.
TEST(FailureKinds, ABoreNearItsAxisIsMeasuredOnThePosesEllipseToo)
{
  for (const auto& [set, seed, index, count] :
       {std::tuple{FrameSet::kHard, 7, 1, 100}, std::tuple{FrameSet::kHard, 7, 56, 100},
        std::tuple{FrameSet::kOblique, 131, 70, 150}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(set, seed, index, count, 640, detector, 0);
    SpoolDetection d;
    expectSlotTargetDetected(detector, frame, 0.01, &d);
    ASSERT_TRUE(d.hole_detected);
    expectHoleOnFrontRim(frame, detector, d);
  }
}

// Seen 20-35 deg off its axis, a spool whose rim the pose search found about its bore (the axis
// within 0.3 deg) was reported with the pose fitted afterwards on the rim's edges gathered from the
// frame, started from its flange's ellipse: through the rim's near side and a rib it ran to a pose
// 7-29 deg off (oblique seed 19 #8, seed 7 #89, seed 97 #0 of 100 at 640x480, up to 4% deep or short;
// seed 19 #10 of 50 at 1280x720). Measured alike by moving edges, the searched pose's rim is
// supported more: reported, the axis is within 1.5 deg and the depth within 1%.
TEST(FailureKinds, AnObliqueSpoolIsReportedAtThePoseItsRimWasFoundAt)
{
  for (const auto& [seed, index, count, width] : {std::tuple{19, 8, 100, 640}, std::tuple{7, 89, 100, 640},
                                                  std::tuple{97, 0, 100, 640}, std::tuple{19, 10, 50, 1280}})
    expectObliquePose(seed, index, count, width, 0.01, 1.5 * kDeg);
}

// The pose a rim search found about a bore (its centre fitted within 5% of the rim's size of
// it) was measured again at the report about the hole, measured since and up to 8 px from the
// pose's own centre: its rim kept no fit there, and the pose fitted on the gathered edges was
// reported, 6-25 deg off the axis and up to 6% off in depth (oblique seed 19 #94, 7 #40, 37 #83
// and 89 #99 of 100 at 640x480). Measured then about the centre it projects to, the searched
// pose is supported more: the axis within 2 deg, the depth within 1%.
TEST(FailureKinds, ASearchedPoseIsMeasuredAboutTheBoreCentreItProjectsTo)
{
  for (const auto& [seed, index] : {std::pair{19, 94}, std::pair{7, 40}, std::pair{37, 83}, std::pair{89, 99}})
    expectObliquePose(seed, index, 100, 640, 0.01, 2.0 * kDeg);
}

// Seen 27-38 deg off its axis, a spool found as a circle about its bore that no rim search gave
// (a circle of either polarity, round or nearly so) was reported at the pose fitted from the
// circle's start on its gathered edges, 4-21 deg off the axis and up to 9% off in depth (oblique
// seed 19 #13, 89 #5, 97 #81 and 7 #96 of 100 at 640x480; 89 #5 at 55 cm, its face half cut by
// the frame). That pose's rim kept under half of its samples, or no fit: the rim searched about
// the bore, supported more, gives the pose reported.
TEST(FailureKinds, AnObliqueCircleNoRimSearchGaveIsReportedAtTheRimSearchedAboutItsBore)
{
  for (const auto& [seed, index] : {std::pair{19, 13}, std::pair{89, 5}, std::pair{97, 81}, std::pair{7, 96}})
    expectObliquePose(seed, index, 100, 640, 0.015, 2.0 * kDeg);
}

// A pose well supported by its rim (0.6-0.85 of its samples) can still be 10-25 deg short of the
// axis where the rim is mostly the part a frontal circle shares with the ellipse (the top and the
// bottom): it was reported 3.4-5.5 deg off (oblique seed 19 #56 and 47 #88 of 100 at 640x480, 97
// #10 of 100 at 320x240, 19 #8 of 60 at 1280x720). The bore's own rim bears out a more oblique
// ellipse: the rim searched about it then gives the pose reported.
TEST(FailureKinds, APoseShortOfTheAxisTheBoreBearsOutIsSearchedAgain)
{
  for (const auto& [seed, index, count, width] : {std::tuple{19, 56, 100, 640}, std::tuple{47, 88, 100, 640},
                                                  std::tuple{97, 10, 100, 320}, std::tuple{19, 8, 60, 1280}})
    expectObliquePose(seed, index, count, width, 0.015, 2.0 * kDeg);
}

// Where the pose comes from the rim searched about the bore, the flange found as a round circle
// about that bore was still reported as that circle: a quarter of its size off the rim's centre
// and up to 17% too large, so the right spool, at the right depth, scored as a wrong detection
// (oblique seed 47 #1, #93 and 89 #42 of 100 at 640x480). It is reported as the pose's rim.
TEST(FailureKinds, AFlangeIsReportedAsTheRimOfThePoseTaken)
{
  for (const auto& [seed, index] : {std::pair{47, 1}, std::pair{47, 93}, std::pair{89, 42}})
    expectObliqueTarget(seed, index, 100, 25.0 * kDeg);
}

// The flange found outside an inner ring (a rib ring taken first, the outermost concentric rim
// agreeing with the bore searched outwards in a window) came with the pose its round circle gave,
// 19.5 and 43.8 deg off the axis and scored as a wrong detection (oblique seed 7 #11 and #84 of 100
// at 640x480). Its pose is checked as a whole frame's is: within 4 deg and 2% now.
TEST(FailureKinds, AFlangeOutsideAnInnerRingHasItsPoseChecked)
{
  for (const int index : {11, 84})
    expectObliquePose(7, index, 100, 640, 0.02, 4.0 * kDeg);
}

// Seen 30-40 deg off its axis, the rim searched about the bore of a flange found outside an inner
// ring was the inner ring's own (0.83-0.91 of the flange's height), its axis right: refused for its
// height, the flange kept the pose its round circle gave, 8-45 deg off the axis (oblique seed 7 #27,
// 37 #34, 47 #98, 89 #39 and 97 #80 of 100 at 640x480; 97 #80 13% deep, its flange cut by the
// frame). That pose scaled out to the flange's height, the rim measured there, is reported: the axis
// within 2 deg, the depth within 1%.
TEST(FailureKinds, AnInnerRingsPoseScaledOutToTheFlangeOutsideItIsReported)
{
  for (const auto& [seed, index] :
       {std::pair{7, 27}, std::pair{37, 34}, std::pair{47, 98}, std::pair{89, 39}, std::pair{97, 80}})
    expectObliquePose(seed, index, 100, 640, 0.01, 2.0 * kDeg);
}

// Seen 30-36 deg off its axis, a flange outside a rib ring was found, but refused: the bore
// measured at its own size (an ellipse about the ring's pose) lay 2.8-10.7 px from the hole the
// rim's window fitted (a circle), or the rim's window put it 0.05 px under its lower bound. The
// rib ring was reported, 13-17% deep (packed_oblique seed 43 #24 of 100 at 640x480, oblique seed 97
// #80 of 100 at 320x240). The flange is taken: its depth within 1%.
TEST(FailureKinds, AFlangeOutsideAnObliqueRibRingIsTakenAboutTheHoleItWasFoundWith)
{
  for (const auto& [set, seed, index, width] :
       {std::tuple{FrameSet::kPackedOblique, 43, 24, 640}, std::tuple{FrameSet::kOblique, 97, 80, 320}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " + std::to_string(width));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(set, seed, index, 100, width, detector);
    const auto target = spool_vision::targetSpool(frame.truth);
    ASSERT_TRUE(target && target->in_slot);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    ASSERT_TRUE(d.detected && d.hole_detected);
    EXPECT_NEAR(d.distance, target->distance, 0.01 * target->distance);
  }
}

// The same agreement about the hole an inner ring was found with asks a rim the frame's search
// would take: seen 36 deg off its axis, a right flange whose weak hole (0.28) measured 23% large
// was taken for an inner ring, and a circle of 0.36 about that hole, a back flange's outline, was
// reported outside it 15% short (oblique seed 185 #48 of 300 at 640x480). The flange stays: its
// depth within 2%.
TEST(FailureKinds, AWeakCircleAboutAnInnerRingsHoleIsNotTakenForItsFlange)
{
  SpoolDetector detector;
  expectSlotTargetDetected(detector, renderSetFrame(FrameSet::kOblique, 185, 48, 300, 640, detector), 0.02);
}

// Seen 32 deg off its axis, a rib ring 0.83 of the flange's size was found as a round circle about
// the bore, whose circle fit agreed with it (21.5 px for a bore 23.9 px high); the pose searched
// about the bore was the ring's, right in axis, and reported 20% deep (packed_oblique seed 43 #37
// of 100 at 640x480). On that pose the bore measures 1.2 times what the ring allows: the flange is
// searched outside it and given the ring's pose scaled out to it. The depth within 1%, the axis
// within 2 deg.
TEST(FailureKinds, ARibRingsPoseOnWhichTheBoreIsTooLargeLeadsToTheFlange)
{
  SpoolDetector detector;
  const RenderedFrame frame = renderSetFrame(FrameSet::kPackedOblique, 43, 37, 100, 640, detector);
  SpoolDetection d;
  expectSlotTargetDetected(detector, frame, 0.01, &d);
  ASSERT_TRUE(std::isfinite(d.axis[2]));
  EXPECT_LT(std::acos(std::clamp(d.axis.dot(frame.truth.axis), -1.0, 1.0)), 2.0 * kDeg)
      << "axis " << d.axis << ", truth " << frame.truth.axis;
}

// Seen 28 deg off its axis at 1.04 m, no flange circle led to the spool, and the rim searched about
// its bore was a rib ring 0.86 of the flange, its depth 17% long: refused, since the bore measured
// at its own size is 1.12 times what the ring allows, and nothing was reported (packed_oblique seed
// 43 #81 of 100 at 640x480). That ring leads outwards as a rib ring does: the flange is found, its
// depth within 3%.
TEST(FailureKinds, ARimSearchedAboutABoreTooLargeForItLeadsToTheFlangeOutsideIt)
{
  SpoolDetector detector;
  expectSlotTargetDetected(detector, renderSetFrame(FrameSet::kPackedOblique, 43, 81, 100, 640, detector), 0.03);
}

// A rib ring found about a bore, then refused as an outline larger than its bore allows (the result
// cleared), was still taken as an inner ring: the outer rim's window was sized from a cleared
// flange (NaN), and the Hough search threw (packed_oblique seed 187 #10 of 15 at 1280x720, in the
// second search). Nothing is left to lead outwards there: no spool, no error.
TEST(FailureKinds, ARibRingRefusedAsAnOutlineLeadsNowhere)
{
  SpoolDetector detector;
  const RenderedFrame frame = renderSetFrame(FrameSet::kPackedOblique, 187, 10, 15, 1280, detector, 720);
  SpoolDetection d;
  ASSERT_NO_THROW(d = detector.detect(frame.image, PixelFormat::kBgr8));
  EXPECT_TRUE(!d.detected || std::isfinite(d.distance));
}

// Seen 30-40 deg off its axis, a spool's front and back flanges make one outline, and a circle
// fitted to it is 15-25% larger than the front rim and off the bore towards the back flange; the
// matcher's oblique tolerances take it with the bore inside, and its depth is 8-12% short (oblique
// seed 7 #14, seed 19 #62, seed 37 #88 of 100 at 640x480). The bore at its own size is under 0.8
// of what that circle allows, with no lit lens to explain it: the front rim is found about the
// bore instead, its depth within 3%.
TEST(FailureKinds, AnOutlineLargerThanItsBoreAllowsIsNotTheFlange)
{
  for (const auto& [seed, index] : {std::pair{7, 14}, std::pair{19, 62}, std::pair{37, 88}})
    expectObliqueTarget(seed, index, 100, 30.0 * kDeg);
}

// Near its axis, a bore seen through shows a lit lens in part of it, and the hole circle followed
// the lens's edge, 7-12 px off the bore's centre: beyond the reach of the fit at the size the
// flange gives it, which failed, so the lens circle stood; the pose's axis came out 16 deg off and
// the depth 3.6-4.0% short (approach_hard seed 83011 #4 of 40 at 1.0 m, 640x480 and 1280x720;
// hard seed 7 #27 of 100 at 640x480, 16 px off, 3.8% long). Measured about the flange's centre the
// bore is found: its centre within 2 px, the depth within 1%.
TEST(FailureKinds, ABoreMissedAboutALensCircleIsMeasuredAboutTheFlangesCentre)
{
  for (const auto& [set, seed, index, count, width] :
       {std::tuple{FrameSet::kApproachHard, 83011, 4, 40, 640}, std::tuple{FrameSet::kApproachHard, 83011, 4, 40, 1280},
        std::tuple{FrameSet::kHard, 7, 27, 100, 640}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index) + " at " + std::to_string(width));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(set, seed, index, count, width, detector, width == 1280 ? 720 : 0);
    const auto target = spool_vision::targetSpool(frame.truth);
    ASSERT_TRUE(target && target->in_slot && frame.truth.hole);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    ASSERT_TRUE(d.detected && d.hole_detected);
    ASSERT_TRUE(spool_vision::flangeMatches(target->flange, d.flange));
    EXPECT_LE(std::hypot(d.hole.x - frame.truth.hole->x, d.hole.y - frame.truth.hole->y), 2.0)
        << "hole (" << d.hole.x << ", " << d.hole.y << "), truth (" << frame.truth.hole->x << ", "
        << frame.truth.hole->y << ")";
    EXPECT_NEAR(d.distance, frame.truth.distance, 0.01 * frame.truth.distance);
  }
}

// The same outline's circle, weak (0.46-0.58 of its rim), where no front rim is found about the
// bore either: its four best-covered coarse poses are the outline and rib rings, and none fits.
// It was reported, its circle 7-26% larger than the flange and up to 50 px off it, the depth up to
// 11% short (oblique seed 89 #72, #90 of 100 at 640x480; seed 43 #7 of 100 at 320x240). Such a
// circle is no spool: nothing, or the target, is reported. Nor is the frame searched again with a
// larger edge budget: on oblique seed 43 #7 at 640x480 that search took a rib ring about the bore,
// 63% deep, where the outline had been 6% short.
TEST(FailureKinds, AWeakOutlineLargerThanItsBoreAllowsWithNoFrontRimIsNoSpool)
{
  for (const auto& [seed, index, width] :
       {std::tuple{89, 72, 640}, std::tuple{89, 90, 640}, std::tuple{43, 7, 320}, std::tuple{43, 7, 640}})
  {
    SCOPED_TRACE(obliqueTrace(seed, index, width));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, seed, index, 100, width, detector);
    const auto target = spool_vision::targetSpool(frame.truth);
    ASSERT_TRUE(target);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    EXPECT_TRUE(!d.detected || spool_vision::flangeMatches(target->flange, d.flange))
        << "detected (" << d.flange.x << ", " << d.flange.y << ") r " << d.flange.r << ", target (" << target->flange.x
        << ", " << target->flange.y << ") r " << target->flange.r;
  }
}

// Seen 25-40 deg off its axis at 160x120, a spool's dark bore measures 3-6 px: under the size the
// bores leading to a rim were searched at (kMinKnownSizeRadius), and no flange circle led to it
// either (its outline is no circle), so nothing was reported (oblique seed 7 #31, #35, seed 89 #0,
// #2 of 100). Where no larger bore leads to a spool, the smaller ones do: each target is found,
// its depth within 3%. The larger bores are still searched first: the lit lens inside a bore of 6-7
// px (hard seed 7 #10, seed 89 #1 of 100) led to a rib ring 23% deep, or to nothing, where the bore
// leads to the target.
TEST(FailureKinds, ABoreUnderSixPixelsLeadsToTheRimWhereNoLargerBoreDoes)
{
  for (const auto& [set, seed, index] : {std::tuple{FrameSet::kOblique, 7, 31}, std::tuple{FrameSet::kOblique, 7, 35},
                                         std::tuple{FrameSet::kOblique, 89, 0}, std::tuple{FrameSet::kOblique, 89, 2},
                                         std::tuple{FrameSet::kHard, 7, 10}, std::tuple{FrameSet::kHard, 89, 1}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index) + " at 160x120");
    SpoolDetector detector;
    expectSlotTargetDetected(detector, renderSetFrame(set, seed, index, 100, 160, detector), 0.03);
  }
}

namespace
{
// Oblique frames `index` of `count` from `seed` at `width` columns: in each the slot's spool is the
// target, found, its depth within 3%.
struct ObliqueFrame
{
  int seed;
  int index;
  int count;
  int width;
};
void expectObliqueTargetsFound(std::initializer_list<ObliqueFrame> frames)
{
  for (const ObliqueFrame& f : frames)
  {
    SCOPED_TRACE("oblique seed " + std::to_string(f.seed) + " #" + std::to_string(f.index) + " of " +
                 std::to_string(f.count) + " at " + std::to_string(f.width));
    SpoolDetector detector;
    expectSlotTargetDetected(detector, renderSetFrame(FrameSet::kOblique, f.seed, f.index, f.count, f.width, detector),
                             0.03);
  }
}
}  // namespace

// A dark bore seen 27-39 deg off its axis, shaded across, whose Hough circle fitted its darker part
// at 0.7 of its height: the rim about it was right, but the circle was too small for the rim to
// agree with, and nothing was reported (oblique seed 89 #55, seed 37 #0 of 100 at 640x480). The
// bore measured at the size the rim gives it agrees.
TEST(FailureKinds, ADarkBoreFittedSmallLeadsToTheRimItsOwnSizeAgreesWith)
{
  expectObliqueTargetsFound({{89, 55, 100, 640}, {37, 0, 100, 640}});
}

// A ribbed face seen 26-39 deg off its axis: about its bore the rings of its ribs covered their
// coarse samples as fully as the rim did, the best of them on the mirrored axis, where no rim lies
// outside it; nothing was reported (oblique seed 37 #19, seed 89 #7 of 100 at 640x480), or the rib
// 19% deep (seed 109 #34 of 300 at 160x120). The nearest pose covering nearly as much of its rim is
// fitted too.
TEST(FailureKinds, ARibRingOnTheMirroredAxisGivesWayToTheRimNearerTheCamera)
{
  expectObliqueTargetsFound({{37, 19, 100, 640}, {89, 7, 100, 640}, {109, 34, 300, 160}});
}

// Frames whose edges filled the budget gave nothing in the first search; the second found the
// target about its dark bore, seen 29-38 deg off its axis, and dropped it: that bore's free circle
// scored 0.5-0.6 (oblique seed 19 #96, seed 89 #64 of 100 at 640x480). Measured at the size the
// rim gives it, the bore agrees with the rim.
TEST(FailureKinds, TheSecondSearchTakesASpoolWhoseBoreAgreesAtItsOwnSize)
{
  expectObliqueTargetsFound({{19, 96, 100, 640}, {89, 64, 100, 640}});
}

// The second search found the target with a circle of either polarity about a bore whose free
// circle scored 0.74 and dropped it (oblique seed 131 #3 of 150, seed 97 #20 of 100 at 640x480,
// 34-39 deg off the axis). Measured at the size the rim gives it, the bore agrees with the rim.
TEST(FailureKinds, TheSecondSearchTakesAnySpoolWhoseBoreAgreesAtItsOwnSize)
{
  expectObliqueTargetsFound({{131, 3, 150, 640}, {97, 20, 100, 640}});
}

// A weak circle through an oblique rim and its back flange's silhouette, matched with a hole rim
// on the face's texture (a rib's arc a sixth of the rim off the bore, neither darker nor lighter
// than the face): taken as the spool, 16-30% off in depth (oblique seed 97 #44, #84, #91 of 100 at
// 320x240, seed 7 #21 of 100 at 160x120). Such a hole is no bore, and the search about the dark
// bore finds the rim.
TEST(FailureKinds, AWeakCircleAboutAHoleThatShowsNoBoreGivesWayToTheRimAboutTheBore)
{
  expectObliqueTargetsFound({{97, 44, 100, 320}, {97, 84, 100, 320}, {97, 91, 100, 320}, {7, 21, 100, 160}});
}

// A neighbour's solid rim taken where the target, nearer the puller and seen 26-28 deg off its
// axis, showed a sharp 4 px bore: the search for a spool nearer the reference took only bores of
// 6 px and up (oblique seed 109 #151, seed 131 #199 of 300 at 160x120). Sought about the sharp
// bores under 6 px too, the target is found.
TEST(FailureKinds, ASmallSharpBoreNearerThePullerReplacesANeighbour)
{
  expectObliqueTargetsFound({{109, 151, 300, 160}, {131, 199, 300, 160}});
}

// Seen 27-39 deg off its axis at 160x120, a flange's Hough circle lies between its ellipse's
// semi-axes or about its back flange's silhouette: a weak circle (under 0.8) about a dark bore, it was
// either dropped by the second search (oblique seed 131 #11 of 300, seed 89 #31 of 100) or taken
// 21-27% off in depth (seed 109 #149, seed 131 #107 of 300). The rim is too small, and has too few
// samples, for its own pose's fit to be measured; the rim searched about the bore is the flange.
TEST(FailureKinds, AWeakCircleAboutASharpBoreGivesWayToTheRimSearchedAboutIt)
{
  expectObliqueTargetsFound({{131, 11, 300, 160}, {89, 31, 100, 160}, {109, 149, 300, 160}, {131, 107, 300, 160}});
}

// Whole and cut faces 32-37 deg off their axes at 640x480, their dark bores plain: about the bore,
// the pose search fitted the four poses covering most of their coarse samples, all rib rings (a rim
// borders its own back flange along a third of it and covers 0.6-0.8 of its samples, a ring inside
// it all of them) whose 3-D fits fail, and nothing was reported (oblique seed 37 #67, seed 7 #34 of
// 100, seed 131 #33 of 150). Where none of those fits, the next best covered poses are fitted.
TEST(FailureKinds, ARimCoveringFewerCoarseSamplesThanItsRibRingsIsFittedWhereTheyFail)
{
  expectObliqueTargetsFound({{37, 67, 100, 640}, {7, 34, 100, 640}, {131, 33, 150, 640}});
}

// A shelf seen from beside it at 160x120: the neighbour seen 10 deg off its axis is taken, while
// the target beside it, nearer the puller and seen 30-40 deg off (the same axis, farther from the
// line of sight), has no circle over min_score and a 3-4 px bore too small for its rim to be
// fitted. Its ellipse is rounded by stretching the frame's columns about the taken spool's axis
// (nearerTurnedFlange()); the circle found there leans towards the back flange's silhouette, and
// the rim's centre is fitted within a tenth of its size of it (the packed_oblique frames).
TEST(FailureKinds, ANearerFlangeTurnedFartherFromTheCameraIsFoundAboutTheTakenSpoolsAxis)
{
  for (const auto& [set, seed, index] :
       {std::tuple{FrameSet::kOblique, 7, 74}, std::tuple{FrameSet::kOblique, 103, 39},
        std::tuple{FrameSet::kOblique, 109, 67}, std::tuple{FrameSet::kOblique, 131, 145},
        std::tuple{FrameSet::kPackedOblique, 7, 127}, std::tuple{FrameSet::kPackedOblique, 7, 135},
        std::tuple{FrameSet::kPackedOblique, 43, 69}, std::tuple{FrameSet::kPackedOblique, 43, 129}})
  {
    SCOPED_TRACE(spool_vision::toString(set));
    expectTargetFlange(seed, index, 200, set, 160);
  }
}

// Seen 35-40 deg off its axis, a spool's outline with its back flange's silhouette was fitted by a
// circle whose centre lay more than kObliqueBoreShift of its size aside of the front bore, and no
// other circle led to the bore: nothing was reported. The sharp bores beside that window, in its
// rows, lead to the rim (SpoolDetector::besideSilhouette()).
TEST(FailureKinds, ASharpBoreBesideAJointSilhouettesCircleLeadsToTheObliqueSpool)
{
  for (const auto& [set, seed, index, count, width] :
       {std::tuple{FrameSet::kOblique, 131, 22, 150, 320}, std::tuple{FrameSet::kOblique, 97, 34, 100, 320},
        std::tuple{FrameSet::kHard, 103, 80, 150, 640}, std::tuple{FrameSet::kOblique, 47, 10, 50, 1280}})
  {
    SCOPED_TRACE(spool_vision::toString(set));
    expectTargetFlange(seed, index, count, set, width, width == 1280 ? 720 : 0);
  }
}

// Seen 28-36 deg off its axis from 56-59 cm, a face the frame cuts (half to two thirds of its rim
// in view) kept 25-50 of its rim's 96 samples, and no pose about its bore found the 30 in the 3-D
// fit's band: nothing was reported. With no spool taken, the best poses are measured again with
// as many samples in view as a whole rim has (RimPoseSearch::search's in_view_retry).
TEST(FailureKinds, AFaceTheFrameCutsIsMeasuredAsDenselyInViewAsAWholeRim)
{
  for (const auto& [seed, index, count, width] : {std::tuple{7, 0, 100, 640}, std::tuple{89, 61, 100, 640},
                                                  std::tuple{131, 83, 150, 320}, std::tuple{131, 55, 60, 1280}})
    expectTargetFlange(seed, index, count, FrameSet::kOblique, width, width == 1280 ? 720 : 0);
}

// Seen 30-40 deg off its axis, a rib ring was taken as the flange and its bore, measured at its
// own size, said so, but no rim outside it agreed with the bore: the ring was reported, 13-18%
// deep. It is now no spool, and where the frame is searched again the target is found (seed 131
// #83).
TEST(FailureKinds, AnObliqueRibRingWithNoRimOutsideItIsNoSpool)
{
  expectTargetFlange(131, 83, 150, FrameSet::kOblique, 640);
  for (const auto& [seed, index, count, width] : {std::tuple{7, 10, 100, 640}, std::tuple{131, 68, 150, 320}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, seed, index, count, width, detector, 0);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    if (d.detected)
    {
      EXPECT_NEAR(d.distance, frame.truth.distance, 0.1 * frame.truth.distance);
    }
  }
}

// Seen 26-40 deg off its axis at 160x120, a spool's bore measures 3-4 px and its blurred rim scores
// 0.55-0.7: under the sharp rim asked of bores that small, no spool was sought about it. And where
// the first search filled the edge budget, the second one found the spool about it but could not
// take it (a bore that small passes none of takesSecondSearch()'s tests). Nothing was reported.
TEST(FailureKinds, ABlurredSmallBoreLeadsToTheObliqueSpoolAt160x120)
{
  for (const auto& [seed, index, count] :
       {std::tuple{131, 251, 300}, std::tuple{109, 62, 300}, std::tuple{7, 26, 100}, std::tuple{103, 127, 300}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index));
    expectTargetFlange(seed, index, count, FrameSet::kOblique, 160);
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, seed, index, count, 160, detector, 0);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    EXPECT_NEAR(d.distance, frame.truth.distance, 0.1 * frame.truth.distance);
  }
}

// Seen 30-35 deg off its axis, a spool's rim was taken as a weak round Hough circle about its bore,
// 6-25 deg off its axis by its own pose, whose rim the moving edges supported 0.6-0.75 (the circle
// lies within the reach of the ellipse's samples): measureObliqueRim() judged it measured, and the
// rim's ellipse about the same bore, supported 0.8-0.9, was never searched. Reported 8-12% off
// centre or in size.
TEST(FailureKinds, AWeakRoundCircleAboutAnObliqueRimGivesWayToTheRimsEllipse)
{
  for (const auto& [seed, index, count, width] : {std::tuple{131, 31, 300, 160}, std::tuple{131, 0, 150, 320},
                                                  std::tuple{131, 8, 150, 640}, std::tuple{131, 0, 60, 1280}})
    expectTargetFlange(seed, index, count, FrameSet::kOblique, width, width == 1280 ? 720 : 0);
}

// A spool seen 42-56 deg off its axis shows its front and back flanges and the hub between as one
// outline, and a round circle about its bore through that outline's far side, 1.4 times the front
// rim's height, was reported 28-31% short in depth (packed_oblique seed 185 #83 and #184 of 200,
// oblique seed 89 #88 of 100, at 640x480). The rim searched about the bore found the spool beyond
// 40 deg at a depth the circle's contradicts: nothing is reported, or a spool at its own depth.
TEST(FailureKinds, AJointSilhouetteOfASpoolSeenBeyondTheRangeIsNoSpool)
{
  for (const auto& [set, seed, index, count] :
       {std::tuple{FrameSet::kPackedOblique, 185, 83, 200}, std::tuple{FrameSet::kPackedOblique, 185, 184, 200},
        std::tuple{FrameSet::kOblique, 89, 88, 100}})
  {
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(set, seed, index, count, 640, detector);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    if (!d.detected)
      continue;
    const std::vector<spool_vision::SpoolTruth> spools = spool_vision::renderedSpools(frame.truth);
    const std::optional<size_t> under = spool_vision::spoolUnder(spools, d.flange);
    ASSERT_TRUE(under) << "seed " << seed << " #" << index;
    EXPECT_NEAR(d.distance, spools[*under].distance, 0.1 * spools[*under].distance) << "seed " << seed << " #" << index;
  }
}

// Outside an oblique rib ring (0.88 of the flange, seen 29 deg off the axis) the flange was found
// about a sharp hole 1.8 px off the bore, but the bore measured inside the ring at its own size and
// the ring's hole were 4.6 and 5.0 px off it, 6.3 and 5.9 px from the flange's hole: beyond the
// centre tolerance, so the ring was reported, 16% too far (packed_oblique seed 185 #109 of 200 at
// 640x480). A sharp hole within half a bore radius of either is that bore.
TEST(FailureKinds, AFlangeOutsideARibRingIsTakenAboutItsOwnSharpHole)
{
  expectTargetFlange(185, 109, 200, FrameSet::kPackedOblique);
}

// Outside an inner ring, the window's search found a rib ring (0.85-0.89 of the flange) and nothing
// outside it, the flange being cut by the frame or the puller rod; the rim searched about the bore
// was the flange, 14-16% higher than that "outermost" rim, and was refused for its height: the
// ring was reported 12-18% too far (packed_oblique seed 189 #103 of 200, oblique seed 131 #36 of
// 100, at 640x480). A searched rim higher than the outermost one found is the flange.
TEST(FailureKinds, ASearchedRimOutsideTheOutermostRimFoundIsTheFlange)
{
  for (const auto& [set, seed, index, count] :
       {std::tuple{FrameSet::kPackedOblique, 189, 103, 200}, std::tuple{FrameSet::kOblique, 131, 36, 100}})
  {
    SCOPED_TRACE("seed " + std::to_string(seed) + " #" + std::to_string(index));
    SpoolDetector detector;
    const RenderedFrame frame = renderSetFrame(set, seed, index, count, 640, detector);
    const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
    ASSERT_TRUE(d.detected);
    EXPECT_NEAR(d.distance, frame.truth.distance, 0.03 * frame.truth.distance);
  }
}

// A round rib ring 0.81 of the flange (the flange cut by the frame, seen 38 deg off its axis) was
// reported 19% too far: the rim searched about its bore was the flange, 1.22 times as high and
// within 1.1% of the depth, but its depth was judged against Eq. 3.2 on the ring, 15% off (oblique
// seed 131 #80 of 100 at 320x240). The outermost rim's height gives Eq. 3.2's depth.
TEST(FailureKinds, ASearchedRimHigherThanTheFlangeCircleIsJudgedOnItsOwnHeight)
{
  SpoolDetector detector;
  const RenderedFrame frame = renderSetFrame(FrameSet::kOblique, 131, 80, 100, 320, detector);
  const SpoolDetection d = detector.detect(frame.image, PixelFormat::kBgr8);
  ASSERT_TRUE(d.detected);
  EXPECT_NEAR(d.distance, frame.truth.distance, 0.03 * frame.truth.distance);
}
