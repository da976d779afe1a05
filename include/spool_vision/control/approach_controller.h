// A reference controller that drives a forklift-like robot onto the bore axis and pushes the
// puller in, reading only what spool_detector publishes (SpoolPose: position, axis, aligned,
// track state). It is an example for integrators and the driver of spool_sim's closed-loop
// trials, not part of the detector (ROS-free: OpenCV types only).
#pragma once

#include <optional>

#include <opencv2/core.hpp>

#include "spool_vision/detector_params.h"

namespace spool_vision
{
/// One frame of what the node publishes, as the controller reads it.
struct ApproachObservation
{
  /// A spool is held: SpoolPose.detected (with ~track, tracking or coasting)
  bool detected = false;
  /// The published values are the tracker's prediction (SpoolPose.track_state == COASTING)
  bool coasting = false;
  bool aligned = false;  ///< SpoolPose.aligned: safe to insert now
  /// m, the bore's front centre, camera optical frame (REP 103: x right, y down, z forward)
  cv::Point3d position;
  /// unit spool axis from the front face into the spool, camera optical frame; NaN until a hole
  /// rim gave one (the controller then uses the optical axis, i.e. "square to the camera")
  cv::Vec3d axis;
};

/// The robot's own dead-reckoned pose in the floor plane (wheel odometry, ROS's `odom` frame):
/// it drifts slowly but has no lag, so it closes the fast loop while vision fixes where the
/// bore's axis lies in it.
struct OdometryPose
{
  double x = 0.0;        ///< m, sideways (right at the start)
  double z = 0.0;        ///< m, forwards (at the start)
  double heading = 0.0;  ///< rad, positive turned right
};

/// What the controller asks of the robot for the next control period.
struct ApproachCommand
{
  double speed = 0.0;      ///< m/s along the heading (positive forward)
  double yaw_rate = 0.0;   ///< rad/s about the vertical axis (positive turns right, the camera's +x)
  double lift_rate = 0.0;  ///< m/s of the camera and puller (positive up)
  bool insert = false;     ///< push the puller straight in along the heading now
};

enum class ApproachPhase
{
  kApproach,  ///< converge on the bore axis while driving to the standoff depth
  kHold,      ///< stopped in the insertion window, waiting for a confirmed `aligned`
  kBackOff,   ///< reversing for another try (no `aligned` in time, or the spool lost)
  kInsert,    ///< `aligned` came: the insertion was commanded
  kGaveUp     ///< max_retries tries used up
};

const char* toString(ApproachPhase phase);

/// Gains and limits. Lengths m, times s, angles rad.
struct ApproachControllerParams
{
  double standoff_depth = 0.56;  ///< depth of the bore's front centre to stop at (in 0.50-0.60)
  double stop_tolerance = 0.01;  ///< the approach ends within this of the standoff depth
  double max_speed = 0.25;       ///< m/s, cruising
  double min_speed = 0.03;       ///< m/s, creeping up to the standoff
  double slow_down = 1.0;        ///< 1/s: speed = slow_down * depth still to go, clamped to the above
  /// m: the heading aims at the axis this far ahead (smaller converges faster, oscillates more)
  double lookahead = 0.15;
  double heading_gain = 3.0;  ///< 1/s, yaw rate per rad of heading error (on odometry)
  /// rad: the heading is never turned so far that the bore's bearing from the camera's optical
  /// axis exceeds this (a field-of-view constraint, as in visual servoing): beyond it the flange
  /// is cut by the image's edge and a neighbour fills the frame, and the tracker loses the spool.
  /// About half the camera's horizontal half-angle (0.17 for a C270-like 44 deg at f = 800 px).
  double max_bore_bearing = 0.17;
  double max_yaw_rate = 0.25;  ///< rad/s
  /// Weight kept by the bore axis's estimate in the odometry frame per new observation (the
  /// rest goes to the observation; odometry's drift is forgotten at this rate)
  double line_memory = 0.8;
  /// m: a pose that puts the bore's front centre this far from where the estimate holds it (in
  /// the odometry frame) disagrees with the robot's own motion (a circle twice too big on a
  /// glossy face halves its depth change per metre driven) and is not fused
  double max_line_jump = 0.03;
  /// disagreeing poses in a row that stop the approach: back off and start the estimate again
  int max_disagreements = 3;
  double lift_gain = 2.0;         ///< 1/s, lift rate per m of height error
  double max_lift_rate = 0.05;    ///< m/s
  double hold_timeout = 3.0;      ///< s in the window without `aligned` before backing off
  double lost_timeout = 1.5;      ///< s without a held spool before backing off
  double backoff_distance = 0.3;  ///< m reversed before approaching again
  double backoff_speed = 0.15;    ///< m/s
  int max_retries = 2;            ///< back-offs before giving up
};

/// Approach, hold, insert; back off and retry when the spool is lost or `aligned` does not come.
///
/// Geometry (camera optical frame, the camera level): the puller's axis runs along +z through
/// (puller_offset_x, puller_offset_y, 0); the bore's axis through `position` along `axis`. In
/// the floor plane each observation places the bore axis in the odometry frame, where a running
/// average keeps it (the spool does not move); the controller steers the heading, on odometry,
/// towards the point of that axis `lookahead` ahead of the puller (a Stanley-style line
/// follower: vision's lag stays out of the fast loop), slows down
/// towards the standoff depth and stops there; the lift puts the puller at the bore's front
/// centre height. In the window it only turns in place (the puller is the turning point), aiming
/// the push through the bore (the heading that makes the puller's misses at the bore's front and
/// at bore_length_max equal and opposite), and waits for `aligned`; a lateral error too large for
/// that needs a new run-up, which the back-off gives.
class ApproachController
{
public:
  /// Throws std::invalid_argument naming the key when a parameter is out of range.
  ApproachController(const ApproachControllerParams& params, const GeometryParams& geometry);

  /// The command for the period after `observation`, taken at `odometry`, dt (s, > 0) after the
  /// previous call. Throws std::invalid_argument on dt <= 0.
  ApproachCommand update(const ApproachObservation& observation, const OdometryPose& odometry, double dt);

  ApproachPhase phase() const
  {
    return phase_;
  }
  /// The puller's lateral and heading errors against the bore axis as the controller holds it
  /// (floorErrors() of its estimate, seen from `odometry`) and the depth still to go to the
  /// standoff (m, rad, m). False (and nothing written) before a spool was held.
  bool errors(const OdometryPose& odometry, double& lateral, double& heading, double& depth_to_go) const;
  int retries() const
  {
    return retries_;
  }

  /// The puller's signed distance from the bore axis in the floor plane (m, positive: the puller
  /// is right of the axis) and the heading error (rad, positive: the axis heads right of the
  /// optical axis, turn right), from one observation. NaN without a position.
  static void floorErrors(const ApproachObservation& observation, const GeometryParams& geometry, double& lateral,
                          double& heading, double& depth_to_face);

private:
  /// The bore axis in the odometry frame: its front centre and heading.
  struct AxisLine
  {
    double x = 0.0;
    double z = 0.0;
    double heading = 0.0;
  };
  /// False when the pose disagrees with the estimate (not fused).
  bool observeLine(const ApproachObservation& observation, const OdometryPose& odometry);
  /// floorErrors() of the estimated line seen from `odometry`.
  void lineErrors(const OdometryPose& odometry, double& lateral, double& heading, double& depth_to_face) const;
  /// The estimated bore front centre seen from `odometry`: (x, z) in the camera frame, m.
  cv::Point2d boreInCamera(const OdometryPose& odometry) const;
  ApproachCommand approach(const ApproachObservation& observation, const OdometryPose& odometry);
  ApproachCommand steer(const ApproachObservation& observation, const OdometryPose& odometry, double speed) const;

  ApproachControllerParams params_;
  GeometryParams geometry_;
  ApproachPhase phase_ = ApproachPhase::kApproach;
  std::optional<AxisLine> line_;
  double phase_time_ = 0.0;   ///< s in the current phase
  double unseen_time_ = 0.0;  ///< s since a spool was last held
  double reversed_ = 0.0;     ///< m reversed in this back-off
  int retries_ = 0;
  int disagreements_ = 0;  ///< poses in a row that disagreed with the estimate
};

}  // namespace spool_vision
