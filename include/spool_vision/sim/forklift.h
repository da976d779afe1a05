// A kinematic forklift for spool_sim's closed loop: the floor-plane pose (unicycle), a lift, its
// velocity and acceleration limits and an actuation error, so that vision must close the loop.
//
// Frame: the renderer's world (render/spool_renderer.h) seen from above: x right along the
// shelf, z along the target spool's axis into the shelf, the bore's front centre at x = 0, z = 0.
// The camera is the robot's reference point and its turning point; the puller hangs
// GeometryParams::puller_offset_y below it and turns with it.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "spool_vision/control/approach_controller.h"
#include "spool_vision/render/spool_renderer.h"
#include "spool_vision/spool_tracker.h"

namespace spool_vision
{
struct ForkliftState
{
  double x = 0.0;                                  ///< m, camera right of the bore axis
  double depth = 1.0;                              ///< m, camera in front of the spool's front face (world z = -depth)
  double heading = 0.0;                            ///< rad from the spool axis, positive turned right (CameraPose::yaw)
  double lift = GeometryParams{}.puller_offset_y;  ///< m, camera above the bore axis
  double speed = 0.0;                              ///< m/s, actual, along the heading
  double yaw_rate = 0.0;                           ///< rad/s, actual
};

struct ForkliftLimits
{
  double max_speed = 0.35;            ///< m/s
  double max_acceleration = 0.5;      ///< m/s^2
  double max_yaw_rate = 0.5;          ///< rad/s
  double max_yaw_acceleration = 2.0;  ///< rad/s^2
  double max_lift_rate = 0.06;        ///< m/s
};

/// How the drive differs from the command (a per-robot scale error and per-period noise), and
/// the odometry from the drive.
struct ActuationError
{
  double speed_scale = 1.0;     ///< actual / commanded speed
  double yaw_rate_scale = 1.0;  ///< actual / commanded yaw rate
  double lift_scale = 1.0;      ///< actual / commanded lift rate
  double noise = 0.0;           ///< relative 1 sigma of each rate, drawn per period
  double odometry_scale = 1.0;  ///< odometry's distance / the distance actually driven
  double gyro_scale = 1.0;      ///< odometry's turn / the turn actually made
};

class Forklift
{
public:
  Forklift(const ForkliftState& start, const ForkliftLimits& limits, const ActuationError& error, std::uint64_t seed);

  /// Drives `dt` s on `command` (its rates limited, then the actuation error applied). `insert`
  /// is not driven here (spool_sim judges it from the pose).
  void step(const ApproachCommand& command, double dt);

  const ForkliftState& state() const
  {
    return state_;
  }

  /// Dead reckoning from the actual rates with the odometry's scale errors, from (0, 0, 0) at
  /// the start.
  const OdometryPose& odometry() const
  {
    return odometry_;
  }

  /// The camera's pose for SpoolRenderer (pitch 0: the lift keeps the camera level).
  CameraPose cameraPose() const;

private:
  ForkliftState state_;
  OdometryPose odometry_;
  ForkliftLimits limits_;
  ActuationError error_;
  cv::RNG rng_;
};

/// The camera's motion (SpoolTracker's CameraMotion, optical frame) from odometry pose `from` to
/// `to`: the camera turns about its own vertical axis (y, down) by the heading's change and moves
/// in the floor plane. The lift is not in the odometry.
CameraMotion cameraMotion(const OdometryPose& from, const OdometryPose& to);

}  // namespace spool_vision
