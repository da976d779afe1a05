#include "spool_vision/sim/closed_loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
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

CameraIntrinsics approachCamera(cv::Size size)
{
  if (size.width < 64 || size.height < 48)
    throw std::invalid_argument("spool_sim: image size must be at least 64x48");
  CameraIntrinsics camera = setCamera(FrameSet::kApproachHard, size);
  camera.distortion = c270Distortion();
  return camera;
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
  cv::RNG navigation(mix(seed, 4));
  start.navigation_error.x = navigation.uniform(-0.05, 0.05);
  start.navigation_error.y = navigation.uniform(-0.05, 0.05);
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

ApproachWorld::ApproachWorld(std::uint64_t seed, cv::Size size, const GeometryParams& geometry,
                             const ForkliftLimits& limits)
  : seed_(seed)
  , start_(drawTrialStart(seed))
  , geometry_(geometry)
  , camera_(approachCamera(size))
  , renderer_(camera_)
  , scene_(randomHardScene(SceneKind::kSpool, start_.scene_seed))
  , rod_length_(scene_.puller_rod_length)
  , robot_(start_.robot, limits, start_.actuation, mix(seed, 3))
{
}

double ApproachWorld::tolerance() const
{
  return 0.5 * (scene_.hole_diameter - geometry_.puller_diameter);
}

RenderedFrame ApproachWorld::view(int step, bool draw)
{
  const ForkliftState& state = robot_.state();
  scene_.seed = mix(seed_, 100 + static_cast<std::uint64_t>(step));
  setMotionBlur(state, scene_);
  // The rod's tip stays below the hole's bottom rim in the image, as in approach_hard.
  const double rod_top = geometry_.puller_offset_y - 0.5 * geometry_.puller_diameter;
  const double hole_bottom = (geometry_.puller_offset_y + 0.5 * scene_.hole_diameter) / state.depth;
  scene_.puller_rod_length = std::min(rod_length_, 0.8 * rod_top / hole_bottom);
  return draw ? renderer_.render(scene_, robot_.cameraPose())
              : RenderedFrame{cv::Mat(), renderer_.groundTruth(scene_, robot_.cameraPose())};
}

bool ApproachWorld::droveIntoFace() const
{
  return robot_.state().depth < kMinDepth;
}

TrialOutcome ApproachWorld::judgePush(double& front_miss, double& back_miss) const
{
  const ForkliftState& state = robot_.state();
  pullerMisses(state, geometry_.puller_offset_y, scene_.bore_length, front_miss, back_miss);
  const double at_face = std::abs(state.x + state.depth * std::tan(state.heading));
  if (at_face > 0.5 * scene_.flange_diameter)
    return TrialOutcome::kWrongSpool;
  return std::max(front_miss, back_miss) <= tolerance() ? TrialOutcome::kInserted : TrialOutcome::kCollision;
}

TrialResult runTrial(const TrialConfig& config)
{
  if (!(config.rate > 0.0) || !std::isfinite(config.rate))
    throw std::invalid_argument("spool_sim: rate must be a finite number of Hz > 0");
  if (config.max_steps < 1)
    throw std::invalid_argument("spool_sim: max_steps must be >= 1");
  if (!(config.target_hint_radius >= 0.0) || !std::isfinite(config.target_hint_radius))
    throw std::invalid_argument("spool_sim: target_hint_radius must be a finite number of m >= 0");
  const double dt = 1.0 / config.rate;
  ApproachWorld world(config.seed, config.size, config.detector.geometry, config.limits);
  TrialResult result;
  result.seed = config.seed;
  result.start = world.start();
  result.time_to_insert = result.front_miss = result.back_miss = std::numeric_limits<double>::quiet_NaN();
  result.tolerance = world.tolerance();

  TrackingDetector detector(config.detector);
  detector.detector().setCamera(world.camera());
  ApproachController controller(config.controller, config.detector.geometry);
  const double puller_y = config.detector.geometry.puller_offset_y;

  bool pushed = false;
  bool held_at_end = false;
  OdometryPose last_odometry = world.robot().odometry();
  const OdometryPose start_odometry = last_odometry;
  cv::Vec3d hint_at_start;  // the navigation's slot in the start's camera frame
  for (int step = 0; step < config.max_steps; ++step)
  {
    const ForkliftState state = world.robot().state();
    if (world.droveIntoFace())
    {
      result.outcome = TrialOutcome::kCollision;
      break;
    }
    RenderedFrame frame;
    try
    {
      // The oracle needs no image unless one is kept.
      frame = world.view(step, !config.oracle || config.keep_pictures || config.on_frame);
    }
    catch (const std::invalid_argument&)
    {
      result.outcome = TrialOutcome::kLost;
      break;
    }
    const double time = step * dt;
    if (config.on_frame)
      config.on_frame(step, frame, world.camera());

    TrackedFrame tracked;
    if (!config.oracle)
    {
      std::optional<CameraMotion> motion;
      if (config.odometry_motion && step > 0)
        motion = cameraMotion(last_odometry, world.robot().odometry());
      std::optional<TargetHint> hint;
      if (config.target_hint_radius > 0.0)
      {
        if (step == 0)
          hint_at_start = {frame.truth.position.x + result.start.navigation_error.x, frame.truth.position.y,
                           frame.truth.position.z + result.start.navigation_error.y};
        const CameraMotion since_start = cameraMotion(start_odometry, world.robot().odometry());
        const cv::Vec3d at = since_start.rotation * hint_at_start + since_start.translation;
        hint = TargetHint{{at[0], at[1], at[2]}, config.target_hint_radius};
      }
      tracked = detector.process(frame.image, PixelFormat::kBgr8, time, motion, hint);
    }
    last_odometry = world.robot().odometry();
    const ApproachObservation observation = config.oracle ? observeTruth(frame.truth) : observePublished(tracked);
    const ApproachCommand command = controller.update(observation, world.robot().odometry(), dt);

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
    pullerMisses(state, puller_y, world.boreLength(), record.true_front_miss, record.true_back_miss);
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
      result.outcome = world.judgePush(result.front_miss, result.back_miss);
      break;
    }
    if (controller.phase() == ApproachPhase::kGaveUp)
    {
      result.outcome = held_at_end ? TrialOutcome::kTimeout : TrialOutcome::kLost;
      break;
    }
    world.drive(command, dt);
  }
  if (!pushed && result.outcome != TrialOutcome::kCollision && controller.phase() != ApproachPhase::kGaveUp)
    result.outcome = TrialOutcome::kTimeout;
  result.retries = controller.retries();
  return result;
}

}  // namespace spool_vision
