#include "spool_vision/sim/closed_loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "spool_vision/eval/evaluation.h"
#include "spool_vision/overlay.h"
#include "spool_vision/render/spool_renderer.h"

namespace spool_vision
{
namespace
{
constexpr double kDeg = M_PI / 180.0;
/// m: nearer than this the camera is inside the flange's rim: the robot drove into the face.
constexpr double kMinDepth = 0.3;
/// px at 480 image rows, the focal length the smear from turning is scaled with (the thesis camera's)
constexpr double kFocalAt480 = 800.0;

std::uint64_t mix(std::uint64_t seed, std::uint64_t salt)
{
  // splitmix64's finaliser: neighbouring seeds give unrelated streams.
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + salt;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

/// The smear of the robot's own motion during a 1/30 s exposure (px @480, as approach_hard's):
/// radial from driving, or sideways from turning, whichever is longer.
void setMotionBlur(const ForkliftState& robot, SceneParams& scene)
{
  const double driving = 400.0 * std::abs(robot.speed) / 30.0 / std::max(robot.depth, kMinDepth);
  const double turning = kFocalAt480 * std::abs(robot.yaw_rate) / 30.0;
  scene.motion_blur_radial = driving >= turning;
  scene.motion_blur = std::max(driving, turning);
  scene.motion_blur_angle = 0.0;
}

ApproachObservation observeTruth(const GroundTruth& truth)
{
  ApproachObservation o;
  o.detected = truth.flange.has_value() && std::isfinite(truth.position.z);
  o.aligned = truth.aligned;
  o.position = truth.position;
  o.axis = truth.axis;
  return o;
}

ApproachObservation observePublished(const TrackedFrame& frame)
{
  ApproachObservation o;
  o.detected = frame.published.detected;
  o.coasting = frame.track.state == TrackState::kCoasting;
  o.aligned = frame.published.aligned;
  o.position = frame.published.position;
  o.axis = frame.published.axis;
  return o;
}
}  // namespace

const char* toString(TrialOutcome outcome)
{
  switch (outcome)
  {
    case TrialOutcome::kInserted:
      return "inserted";
    case TrialOutcome::kCollision:
      return "collision";
    case TrialOutcome::kTimeout:
      return "timeout";
    case TrialOutcome::kLost:
      return "lost";
    case TrialOutcome::kWrongSpool:
      return "wrong_spool";
  }
  return "?";
}

TrialStart drawTrialStart(std::uint64_t seed)
{
  cv::RNG rng(mix(seed, 1));
  TrialStart start;
  // In the lane in front of the slot (square to the shelf), then the spool's turn: the renderer's
  // world is the spool's, so the robot's place turns about the bore the other way.
  const double lane_depth = rng.uniform(0.9, 1.2);
  const double lane_x = rng.uniform(-0.15, 0.15);
  const double turn = rng.uniform(-5.0, 5.0) * kDeg;
  start.robot.x = lane_x * std::cos(turn) + lane_depth * std::sin(turn);
  start.robot.depth = lane_depth * std::cos(turn) - lane_x * std::sin(turn);
  // Aimed roughly at the slot: the heading off the bearing of the bore.
  const double bearing = std::atan2(-start.robot.x, start.robot.depth);
  start.robot.heading = bearing + rng.uniform(-10.0, 10.0) * kDeg;
  start.robot.lift = GeometryParams{}.puller_offset_y + rng.uniform(-0.02, 0.02);
  start.actuation.speed_scale = 1.0 + rng.uniform(-0.03, 0.03);
  start.actuation.yaw_rate_scale = 1.0 + rng.uniform(-0.03, 0.03);
  start.actuation.lift_scale = 1.0 + rng.uniform(-0.03, 0.03);
  start.actuation.noise = 0.02;
  start.actuation.odometry_scale = 1.0 + rng.uniform(-0.01, 0.01);
  start.actuation.gyro_scale = 1.0 + rng.uniform(-0.01, 0.01);
  start.scene_seed = mix(seed, 2);
  return start;
}

void pullerMisses(const ForkliftState& robot, double puller_offset_y, double bore_length, double& front, double& back)
{
  // The puller's axis leaves the camera's position puller_offset_y lower, along the heading.
  const double slope = std::tan(robot.heading);
  const double vertical = robot.lift - puller_offset_y;
  front = std::hypot(robot.x + robot.depth * slope, vertical);
  back = std::hypot(robot.x + (robot.depth + bore_length) * slope, vertical);
}

TrialResult runTrial(const TrialConfig& config)
{
  if (config.size.width < 64 || config.size.height < 48)
    throw std::invalid_argument("spool_sim: image size must be at least 64x48");
  if (!(config.rate > 0.0) || !std::isfinite(config.rate))
    throw std::invalid_argument("spool_sim: rate must be a finite number of Hz > 0");
  if (config.max_steps < 1)
    throw std::invalid_argument("spool_sim: max_steps must be >= 1");
  const double dt = 1.0 / config.rate;
  TrialResult result;
  result.seed = config.seed;
  result.start = drawTrialStart(config.seed);
  result.time_to_insert = result.front_miss = result.back_miss = std::numeric_limits<double>::quiet_NaN();

  CameraIntrinsics camera = setCamera(FrameSet::kApproachHard, config.size);
  camera.distortion = c270Distortion();
  const SpoolRenderer renderer(camera);
  TrackingDetector detector(config.detector);
  detector.detector().setCamera(camera);
  ApproachController controller(config.controller, config.detector.geometry);
  Forklift robot(result.start.robot, config.limits, result.start.actuation, mix(config.seed, 3));
  SceneParams scene = randomHardScene(SceneKind::kSpool, result.start.scene_seed);
  const double rod_length = scene.puller_rod_length;
  const double puller_y = config.detector.geometry.puller_offset_y;
  result.tolerance = 0.5 * (scene.hole_diameter - config.detector.geometry.puller_diameter);

  bool pushed = false;
  bool held_at_end = false;
  for (int step = 0; step < config.max_steps; ++step)
  {
    const ForkliftState& state = robot.state();
    if (state.depth < kMinDepth)
    {
      result.outcome = TrialOutcome::kCollision;
      break;
    }
    scene.seed = mix(config.seed, 100 + static_cast<std::uint64_t>(step));
    setMotionBlur(state, scene);
    // The rod's tip stays below the hole's bottom rim in the image, as in approach_hard.
    const double rod_top = puller_y - 0.5 * config.detector.geometry.puller_diameter;
    const double hole_bottom = (puller_y + 0.5 * scene.hole_diameter) / state.depth;
    scene.puller_rod_length = std::min(rod_length, 0.8 * rod_top / hole_bottom);
    RenderedFrame frame;
    try
    {
      // The oracle needs no image unless one is kept.
      frame = config.oracle && !config.keep_pictures
                  ? RenderedFrame{cv::Mat(), renderer.groundTruth(scene, robot.cameraPose())}
                  : renderer.render(scene, robot.cameraPose());
    }
    catch (const std::invalid_argument&)
    {
      // The renderer's "impossible pose": turned so far that part of the front flange is behind
      // the camera. No view of the spool is left to drive on.
      result.outcome = TrialOutcome::kLost;
      break;
    }
    const double time = step * dt;

    TrackedFrame tracked;
    if (!config.oracle)
      tracked = detector.process(frame.image, PixelFormat::kBgr8, time);
    const ApproachObservation observation = config.oracle ? observeTruth(frame.truth) : observePublished(tracked);
    const ApproachCommand command = controller.update(observation, robot.odometry(), dt);

    TrialStep record;
    record.time = time;
    record.robot = state;
    record.phase = controller.phase();
    record.track_state = tracked.track.state;
    record.detected = observation.detected;
    record.aligned = observation.aligned;
    record.truly_aligned = frame.truth.aligned;
    record.true_depth = frame.truth.distance;
    record.published_depth = observation.detected ? observation.position.z : std::numeric_limits<double>::quiet_NaN();
    record.track_front_miss = tracked.track.front_miss;
    record.track_back_miss = tracked.track.back_miss;
    record.track_miss_sigma = tracked.track.miss_sigma;
    pullerMisses(state, puller_y, scene.bore_length, record.true_front_miss, record.true_back_miss);
    result.trajectory.push_back(record);
    result.steps = step + 1;
    result.frames_detected += observation.detected ? 1 : 0;
    result.frames_coasting += observation.coasting ? 1 : 0;
    result.frames_refused += tracked.track.rejected_now ? 1 : 0;
    held_at_end = observation.detected;

    const double depth_error =
        observation.detected ? std::abs(observation.position.z - frame.truth.distance) / frame.truth.distance : 0.0;
    if (config.keep_pictures)
    {
      const SpoolDetection shown = config.oracle ? SpoolDetection() : tracked.published;
      cv::Mat picture = renderOverlay(frame.image, PixelFormat::kBgr8, shown);
      if (step == 0)
        result.first_frame = picture;
      if (result.worst_frame.empty() || depth_error > result.worst_depth_error)
        result.worst_frame = picture;
      result.last_frame = picture;
    }
    result.worst_depth_error = std::max(result.worst_depth_error, depth_error);

    if (command.insert)
    {
      pushed = true;
      result.time_to_insert = time;
      pullerMisses(state, puller_y, scene.bore_length, result.front_miss, result.back_miss);
      const double at_face = std::abs(state.x + state.depth * std::tan(state.heading));
      if (at_face > 0.5 * scene.flange_diameter)
        result.outcome = TrialOutcome::kWrongSpool;
      else if (std::max(result.front_miss, result.back_miss) <= result.tolerance)
        result.outcome = TrialOutcome::kInserted;
      else
        result.outcome = TrialOutcome::kCollision;
      break;
    }
    if (controller.phase() == ApproachPhase::kGaveUp)
    {
      result.outcome = held_at_end ? TrialOutcome::kTimeout : TrialOutcome::kLost;
      break;
    }
    robot.step(command, dt);
  }
  if (!pushed && result.outcome != TrialOutcome::kCollision && controller.phase() != ApproachPhase::kGaveUp)
    result.outcome = TrialOutcome::kTimeout;
  result.retries = controller.retries();
  return result;
}

}  // namespace spool_vision
