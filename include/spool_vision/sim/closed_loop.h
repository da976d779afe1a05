// spool_sim's closed-loop trial: a Forklift whose camera frames are rendered by SpoolRenderer
// (the hard set's webcam, faces and clutter, a C270-like lens, a smear from the robot's own
// motion), read by TrackingDetector, and driven by ApproachController from what the node would
// publish, until the controller pushes the puller in. The renderer's exact geometry judges the
// push. ROS-free.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "spool_vision/control/approach_controller.h"
#include "spool_vision/detector_params.h"
#include "spool_vision/render/spool_renderer.h"
#include "spool_vision/sim/forklift.h"
#include "spool_vision/spool_tracker.h"

namespace spool_vision
{
enum class TrialOutcome
{
  kInserted,   ///< pushed in; the puller's axis within t_f of the bore's at its front and back
  kCollision,  ///< pushed in and the puller would touch the bore or the face, or drove into the face
  kTimeout,    ///< no push within the step budget or the controller's tries
  kLost,       ///< gave up with no spool held (the target out of view or never tracked)
  kWrongSpool  ///< pushed at another slot (the puller's axis meets the face plane off the target's flange)
};

const char* toString(TrialOutcome outcome);

/// Where a trial starts: drawn from its seed (drawTrialStart).
struct TrialStart
{
  ForkliftState robot;
  ActuationError actuation;
  std::uint64_t scene_seed = 0;  ///< randomHardScene's seed: the shelf, lamps, faces, clutter
  /// m, where the robot's navigation puts the slot's bore off the truth (x sideways, z ahead, in
  /// the start's camera frame): the target hint's error (TrialConfig::target_hint_radius)
  cv::Point2d navigation_error;
};

/// A start 0.9-1.2 m in front of the slot and up to 15 cm beside it, the spool's axis turned up to
/// 5 deg from the lane (the renderer turns the shelf with the spool: the robot's place turns about
/// the bore instead), the heading up to 10 deg off the bearing of the bore, the lift up to 2 cm off
/// the bore's height, speed and yaw-rate scale errors of up to 3%
/// and 2% noise per period; the navigation's error on the slot's place up to 5 cm each way (its own
/// stream: the other draws are those of the seed without it). Deterministic in `seed`.
TrialStart drawTrialStart(std::uint64_t seed);

struct TrialConfig
{
  std::uint64_t seed = 1;
  cv::Size size{640, 480};
  double rate = 10.0;   ///< Hz: one frame and one control period each
  int max_steps = 300;  ///< control periods before a timeout
  /// Drive on the renderer's truth instead of the detector (proves the simulation and the
  /// controller: it must insert every time)
  bool oracle = false;
  bool keep_pictures = false;  ///< keep the first, the worst and the last frame with the overlay
  /// Give the tracker the camera's motion between frames from the robot's odometry (cameraMotion),
  /// as the node does with ~odom_frame
  bool odometry_motion = true;
  /// m, > 0: the tracker gets a TargetHint of this radius each frame, the slot's bore where the
  /// robot's navigation puts it at the start (TrialStart::navigation_error off the truth), carried
  /// into each frame's camera frame by the odometry; 0: none (the detector's own target rule)
  double target_hint_radius = 0.0;
  /// Called with every frame the camera sees, before the detector reads it (step from 0, the
  /// camera's intrinsics): how spool_sim --frames records a trial for spool_detect to replay
  std::function<void(int step, const RenderedFrame& frame, const CameraIntrinsics& camera)> on_frame;
  DetectorParams detector;
  ApproachControllerParams controller;
  ForkliftLimits limits;
};

/// One control period.
struct TrialStep
{
  double time = 0.0;  ///< s
  ForkliftState robot;
  ApproachPhase phase = ApproachPhase::kApproach;  ///< after this period's command
  TrackState track_state = TrackState::kSearching;
  bool detected = false;
  bool aligned = false;          ///< published
  bool truly_aligned = false;    ///< the renderer's truth
  double true_depth = 0.0;       ///< m
  double published_depth = 0.0;  ///< m, NaN without a held spool
  /// m, the tracker's puller misses at the bore's front and back and their 1 sigma
  /// (TrackedSpool), what `aligned` is decided on; NaN without them (and for the oracle)
  double track_front_miss = 0.0;
  double track_back_miss = 0.0;
  double track_miss_sigma = 0.0;
  /// m, the true misses (pullerMisses())
  double true_front_miss = 0.0;
  double true_back_miss = 0.0;
};

struct TrialResult
{
  std::uint64_t seed = 0;
  TrialStart start;
  TrialOutcome outcome = TrialOutcome::kTimeout;
  int steps = 0;
  double time_to_insert = 0.0;  ///< s from the start to the push; NaN without one
  /// m, the puller's axis from the bore's at the front face and at the bore's back end, at the
  /// push (truth); NaN without one
  double front_miss = 0.0;
  double back_miss = 0.0;
  double tolerance = 0.0;  ///< m, t_f
  int frames_detected = 0;
  int frames_coasting = 0;
  int frames_refused = 0;
  int retries = 0;
  double worst_depth_error = 0.0;  ///< relative, over the frames with a held spool
  std::vector<TrialStep> trajectory;
  cv::Mat first_frame, worst_frame, last_frame;  ///< BGR with the overlay (keep_pictures)
};

/// The puller's axis against the bore's (the renderer's geometry: bore axis along world z through
/// x = 0 at the hole's height) at the front face and `bore_length` behind it (m).
void pullerMisses(const ForkliftState& robot, double puller_offset_y, double bore_length, double& front, double& back);

/// One trial's world without the vision and the controller: the shelf drawn from the seed, the
/// forklift at its start, the frames its camera sees and the judge of a push. runTrial drives it
/// with TrackingDetector and ApproachController in one process; spool_sim_world (ROS) drives it
/// through topics.
class ApproachWorld
{
public:
  /// Throws std::invalid_argument on a size under 64x48.
  ApproachWorld(std::uint64_t seed, cv::Size size, const GeometryParams& geometry, const ForkliftLimits& limits);

  const TrialStart& start() const
  {
    return start_;
  }
  /// The approach_hard camera at the trial's size with the C270-like lens (c270Distortion)
  const CameraIntrinsics& camera() const
  {
    return camera_;
  }
  const Forklift& robot() const
  {
    return robot_;
  }
  /// m, t_f: half the bore's clearance around the puller
  double tolerance() const;
  /// m, the bore's length (where the back miss is taken)
  double boreLength() const
  {
    return scene_.bore_length;
  }

  /// What the camera sees from the robot's pose now: frame number `step` (each frame its own
  /// noise), smeared by the robot's own motion; `draw` false gives the truth only. Throws
  /// std::invalid_argument for a pose the renderer cannot draw (part of the front flange behind
  /// the camera: no view of the spool is left to drive on).
  RenderedFrame view(int step, bool draw = true);
  /// True once the robot is nearer than 30 cm to the face: inside the flange's rim, it drove in.
  bool droveIntoFace() const;
  /// A push straight in from the pose now, judged on the renderer's geometry: kInserted,
  /// kCollision or kWrongSpool, with the puller's misses at the bore's front and back (m).
  TrialOutcome judgePush(double& front_miss, double& back_miss) const;
  /// Drives `dt` s on `command` (Forklift::step).
  void drive(const ApproachCommand& command, double dt)
  {
    robot_.step(command, dt);
  }

private:
  std::uint64_t seed_;
  TrialStart start_;
  GeometryParams geometry_;
  CameraIntrinsics camera_;
  SpoolRenderer renderer_;
  SceneParams scene_;
  double rod_length_;
  Forklift robot_;
};

/// Runs one trial. Throws std::invalid_argument on a bad configuration (size, rate, steps) and
/// ParamError on bad detector parameters.
TrialResult runTrial(const TrialConfig& config);

}  // namespace spool_vision
