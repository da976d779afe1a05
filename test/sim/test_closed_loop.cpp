#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "spool_vision/eval/evaluation.h"
#include "spool_vision/render/spool_renderer.h"
#include "spool_vision/sim/closed_loop.h"
#include "spool_vision/sim/forklift.h"
#include "spool_vision/spool_tracker.h"

namespace sv = spool_vision;

namespace
{
constexpr double kDeg = M_PI / 180.0;
}

TEST(Forklift, KeepsItsLimitsAndItsOdometryFollowsTheDrive)
{
  sv::ForkliftState start;
  start.depth = 1.0;
  sv::ForkliftLimits limits;
  sv::Forklift robot(start, limits, sv::ActuationError(), 1);
  sv::ApproachCommand full;
  full.speed = 10.0;
  full.yaw_rate = 0.2;
  robot.step(full, 0.1);
  // One period of acceleration from standstill.
  EXPECT_NEAR(robot.state().speed, limits.max_acceleration * 0.1, 1e-12);
  for (int i = 0; i < 50; ++i)
    robot.step(full, 0.1);
  EXPECT_NEAR(robot.state().speed, limits.max_speed, 1e-12);
  EXPECT_NEAR(robot.state().yaw_rate, 0.2, 1e-12);
  // Without errors the odometry is the true motion from the start.
  const sv::OdometryPose& odo = robot.odometry();
  EXPECT_NEAR(odo.x, robot.state().x - start.x, 1e-9);
  EXPECT_NEAR(odo.z, start.depth - robot.state().depth, 1e-9);
  EXPECT_NEAR(odo.heading, robot.state().heading - start.heading, 1e-12);
}

TEST(Forklift, CameraPoseIsTheRenderersConvention)
{
  sv::ForkliftState s;
  s.x = 0.03;
  s.depth = 0.7;
  s.heading = 2.0 * kDeg;
  s.lift = 0.065;
  const sv::Forklift robot(s, sv::ForkliftLimits(), sv::ActuationError(), 1);
  const sv::CameraPose pose = robot.cameraPose();
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::GroundTruth truth = renderer.groundTruth(sv::SceneParams(), pose);
  // The bore's front centre seen from the camera: depth along the heading, the lift below.
  EXPECT_NEAR(truth.position.z, 0.7 * std::cos(s.heading) - 0.03 * std::sin(s.heading), 1e-9);
  EXPECT_NEAR(truth.position.x, -0.03 * std::cos(s.heading) - 0.7 * std::sin(s.heading), 1e-9);
  EXPECT_NEAR(truth.position.y, s.lift, 1e-9);
}

TEST(Forklift, CameraMotionFromOdometryMovesTheSceneAsTheRendererSeesIt)
{
  // Driving and turning without actuation error (odometry = truth): the bore's front centre and
  // the spool axis in the later camera frame are the earlier ones moved by cameraMotion.
  sv::ForkliftState s;
  s.x = 0.08;
  s.depth = 0.9;
  s.heading = -4.0 * kDeg;
  sv::Forklift robot(s, sv::ForkliftLimits(), sv::ActuationError(), 1);
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::SceneParams scene;
  sv::ApproachCommand command;
  command.speed = 0.3;
  command.yaw_rate = 0.4;
  for (int i = 0; i < 5; ++i)
    robot.step(command, 0.1);
  const sv::OdometryPose before = robot.odometry();
  const sv::GroundTruth a = renderer.groundTruth(scene, robot.cameraPose());
  for (int i = 0; i < 3; ++i)
    robot.step(command, 0.1);
  const sv::GroundTruth b = renderer.groundTruth(scene, robot.cameraPose());
  const sv::CameraMotion motion = sv::cameraMotion(before, robot.odometry());
  const cv::Vec3d moved = motion.rotation * cv::Vec3d(a.position.x, a.position.y, a.position.z) + motion.translation;
  EXPECT_NEAR(moved[0], b.position.x, 1e-9);
  EXPECT_NEAR(moved[1], b.position.y, 1e-9);
  EXPECT_NEAR(moved[2], b.position.z, 1e-9);
  const cv::Vec3d turned = motion.rotation * a.axis;
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(turned[k], b.axis[k], 1e-9);
  // It did turn: the test would not see a sign error otherwise.
  EXPECT_GT(std::abs(b.position.x - a.position.x), 0.05);
}

TEST(ClosedLoop, PullerMissesAgreeWithTheRenderersClearance)
{
  const sv::SpoolRenderer renderer(sv::CameraIntrinsics::thesisDefault(640, 480));
  const sv::SceneParams scene;
  const double t_f = 0.5 * (scene.hole_diameter - sv::GeometryParams{}.puller_diameter);
  int clears = 0;
  for (const double x : {-0.003, -0.001, 0.0, 0.0015, 0.004})
    for (const double heading : {-0.8 * kDeg, -0.2 * kDeg, 0.0, 0.5 * kDeg})
      for (const double lift_error : {0.0, 0.002})
      {
        sv::ForkliftState s;
        s.x = x;
        s.depth = 0.56;
        s.heading = heading;
        s.lift = sv::GeometryParams{}.puller_offset_y + lift_error;
        const sv::Forklift robot(s, sv::ForkliftLimits(), sv::ActuationError(), 1);
        const sv::GroundTruth truth = renderer.groundTruth(scene, robot.cameraPose());
        double front = 0.0;
        double back = 0.0;
        sv::pullerMisses(s, sv::GeometryParams{}.puller_offset_y, scene.bore_length, front, back);
        EXPECT_EQ(std::max(front, back) <= t_f, truth.puller_clears) << x << " " << heading << " " << lift_error;
        EXPECT_NEAR(front, truth.puller_miss, 1e-6);
        clears += truth.puller_clears ? 1 : 0;
      }
  EXPECT_GT(clears, 3);
  EXPECT_LT(clears, 37);
}

TEST(ClosedLoop, StartsAreDeterministicAndInTheirRanges)
{
  for (std::uint64_t seed = 1; seed <= 50; ++seed)
  {
    const sv::TrialStart a = sv::drawTrialStart(seed);
    const sv::TrialStart b = sv::drawTrialStart(seed);
    EXPECT_EQ(a.robot.x, b.robot.x);
    EXPECT_EQ(a.scene_seed, b.scene_seed);
    // In the lane: 0.9-1.2 m and +-15 cm, turned by at most 5 deg about the bore.
    const double range = std::hypot(a.robot.x, a.robot.depth);
    EXPECT_GE(range, 0.9);
    EXPECT_LE(range, std::hypot(1.2, 0.15));
    EXPECT_LE(std::abs(a.robot.x), 0.15 + 1.2 * std::sin(5.0 * kDeg));
    EXPECT_LE(std::abs(a.robot.heading - std::atan2(-a.robot.x, a.robot.depth)), 10.0 * kDeg);
    EXPECT_LE(std::abs(a.robot.lift - sv::GeometryParams{}.puller_offset_y), 0.02);
  }
  EXPECT_NE(sv::drawTrialStart(1).robot.x, sv::drawTrialStart(2).robot.x);
}

TEST(ClosedLoop, TheOracleInsertsEveryTime)
{
  // The simulation and the controller on the renderer's truth (no images): any failure here is
  // the controller's or the simulation's, never the detector's.
  for (std::uint64_t seed = 1; seed <= 20; ++seed)
  {
    sv::TrialConfig config;
    config.seed = seed;
    config.oracle = true;
    const sv::TrialResult r = sv::runTrial(config);
    EXPECT_EQ(r.outcome, sv::TrialOutcome::kInserted) << "seed " << seed << ": " << sv::toString(r.outcome);
    EXPECT_LE(std::max(r.front_miss, r.back_miss), r.tolerance) << "seed " << seed;
    EXPECT_LT(r.time_to_insert, 20.0) << "seed " << seed;
  }
}

TEST(ClosedLoop, VisionDrivesThePullerIntoTheBore)
{
  // One trial end to end: rendered frames, the detector and tracker, the controller on what
  // the node publishes. Seed 1 (640x480) needs one back-off and inserts with the puller
  // within 0.5 mm of the bore's axis.
  sv::TrialConfig config;
  config.seed = 1;
  const sv::TrialResult r = sv::runTrial(config);
  EXPECT_EQ(r.outcome, sv::TrialOutcome::kInserted) << sv::toString(r.outcome);
  EXPECT_LE(std::max(r.front_miss, r.back_miss), 0.5 * r.tolerance);
  EXPECT_GT(r.frames_detected, r.steps / 2);
  EXPECT_LT(r.worst_depth_error, 0.05);
}

TEST(ClosedLoop, ARibRingInTheTargetHintsWindowGivesWayToTheFlange)
{
  // Seed 1844 at 640x480, its first frame: a grey face on a grey wall, the flange's rim faint and
  // its outermost rib ring (0.85 of it) whole and strong. The search in the target hint's window
  // took the ring (1.22 m at 1.04 m) and the track never left it; the whole frame's check of the
  // chosen spool (the bore, measured at its own size, is too large for the ring) now runs there.
  sv::ApproachWorld world(1844, {640, 480}, sv::GeometryParams{}, sv::ForkliftLimits{});
  const sv::RenderedFrame frame = world.view(0);
  ASSERT_TRUE(frame.truth.flange && frame.truth.hole_in_view);
  const cv::Point2d error = world.start().navigation_error;
  const sv::TargetHint hint{
      {frame.truth.position.x + error.x, frame.truth.position.y, frame.truth.position.z + error.y}, 0.15};
  sv::TrackingDetector detector(sv::DetectorParams{});
  detector.detector().setCamera(world.camera());
  const sv::TrackedFrame seen = detector.process(frame.image, sv::PixelFormat::kBgr8, 0.0, std::nullopt, hint);
  ASSERT_TRUE(seen.raw.hole_detected);
  EXPECT_NEAR(seen.raw.distance, frame.truth.position.z, 0.03 * frame.truth.position.z);
  EXPECT_NEAR(seen.raw.flange.r_vertical, frame.truth.flange->r_vertical, 0.03 * frame.truth.flange->r_vertical);
}

TEST(ClosedLoop, AFaintFlangeOverfillingTheFrameIsFoundOutsideItsRibRings)
{
  // Seed 1918's shelf: a grey ribbed face on a grey board. At the insertion window the flange
  // overfills the frame (cut at the bottom), its rim is below the frame's edge threshold, and a rib
  // ring (0.82-0.85 of it) was reported with the bore: depth +17% at 58-60 cm, where the track
  // was lost. The bore, measured at its own size, says the ring is too small; the rim the bore's
  // size gives is then measured by moving edges.
  const sv::ApproachWorld world(1918, {640, 480}, sv::GeometryParams{}, sv::ForkliftLimits{});
  sv::SceneParams scene = sv::randomHardScene(sv::SceneKind::kSpool, world.start().scene_seed);
  scene.seed = 5;
  const sv::SpoolRenderer renderer(world.camera());
  sv::SpoolDetector detector;
  detector.setCamera(world.camera());
  for (const double distance : {0.58, 0.60})
  {
    const sv::RenderedFrame frame = renderer.render(scene, sv::bearingPose(distance, 0.0, 0.0, 0.06, 0.0));
    ASSERT_TRUE(frame.truth.flange && frame.truth.hole_in_view);
    ASSERT_LT(frame.truth.flange->visible_fraction, 0.8);
    const sv::SpoolDetection d = detector.detect(frame.image, sv::PixelFormat::kBgr8);
    SCOPED_TRACE("at " + std::to_string(distance) + " m");
    ASSERT_TRUE(d.hole_detected);
    EXPECT_NEAR(d.distance, frame.truth.position.z, 0.01 * frame.truth.position.z);
    EXPECT_NEAR(d.flange.r_vertical, frame.truth.flange->r_vertical, 0.01 * frame.truth.flange->r_vertical);
  }
}

TEST(ClosedLoop, BadConfigurationIsRefused)
{
  sv::TrialConfig config;
  config.rate = 0.0;
  EXPECT_THROW(sv::runTrial(config), std::invalid_argument);
  config = sv::TrialConfig();
  config.size = {10, 10};
  EXPECT_THROW(sv::runTrial(config), std::invalid_argument);
  config = sv::TrialConfig();
  config.max_steps = 0;
  EXPECT_THROW(sv::runTrial(config), std::invalid_argument);
}
