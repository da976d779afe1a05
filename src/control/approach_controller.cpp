#include "spool_vision/control/approach_controller.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace spool_vision
{
namespace
{
void requirePositive(double value, const char* key)
{
  if (!(value > 0.0) || !std::isfinite(value))
    throw std::invalid_argument(std::string("approach controller: ") + key + " must be a finite number > 0, got " +
                                std::to_string(value));
}
}  // namespace

const char* toString(ApproachPhase phase)
{
  switch (phase)
  {
    case ApproachPhase::kApproach:
      return "approach";
    case ApproachPhase::kHold:
      return "hold";
    case ApproachPhase::kBackOff:
      return "back_off";
    case ApproachPhase::kInsert:
      return "insert";
    case ApproachPhase::kGaveUp:
      return "gave_up";
  }
  return "?";
}

ApproachController::ApproachController(const ApproachControllerParams& params, const GeometryParams& geometry)
  : params_(params), geometry_(geometry)
{
  requirePositive(params.standoff_depth, "standoff_depth");
  requirePositive(params.stop_tolerance, "stop_tolerance");
  requirePositive(params.max_speed, "max_speed");
  requirePositive(params.min_speed, "min_speed");
  requirePositive(params.slow_down, "slow_down");
  requirePositive(params.lookahead, "lookahead");
  requirePositive(params.heading_gain, "heading_gain");
  if (!(params.max_bore_bearing > 0.0 && params.max_bore_bearing < 0.5 * M_PI))
    throw std::invalid_argument("approach controller: max_bore_bearing must be in (0, pi/2) rad, got " +
                                std::to_string(params.max_bore_bearing));
  requirePositive(params.max_yaw_rate, "max_yaw_rate");
  requirePositive(params.lift_gain, "lift_gain");
  requirePositive(params.max_lift_rate, "max_lift_rate");
  requirePositive(params.hold_timeout, "hold_timeout");
  requirePositive(params.lost_timeout, "lost_timeout");
  requirePositive(params.backoff_distance, "backoff_distance");
  requirePositive(params.backoff_speed, "backoff_speed");
  if (!(params.line_memory >= 0.0 && params.line_memory < 1.0))
    throw std::invalid_argument("approach controller: line_memory must be in [0, 1), got " +
                                std::to_string(params.line_memory));
  if (params.min_speed > params.max_speed)
    throw std::invalid_argument("approach controller: min_speed must not exceed max_speed (" +
                                std::to_string(params.min_speed) + " > " + std::to_string(params.max_speed) + ")");
  requirePositive(params.max_line_jump, "max_line_jump");
  if (params.max_disagreements < 1)
    throw std::invalid_argument("approach controller: max_disagreements must be >= 1, got " +
                                std::to_string(params.max_disagreements));
  if (params.max_retries < 0)
    throw std::invalid_argument("approach controller: max_retries must be >= 0, got " +
                                std::to_string(params.max_retries));
}

void ApproachController::floorErrors(const ApproachObservation& observation, const GeometryParams& geometry,
                                     double& lateral, double& heading, double& depth_to_face)
{
  const cv::Point3d& p = observation.position;
  double ax = observation.axis[0];
  double az = observation.axis[2];
  const double norm = std::hypot(ax, az);
  if (!(norm > 0.0) || !std::isfinite(norm))
  {
    // No axis yet: take the spool as square to the camera.
    ax = 0.0;
    az = 1.0;
  }
  else
  {
    ax /= norm;
    az /= norm;
  }
  // The puller's point in the floor plane and the bore axis line through p along (ax, az).
  const double dx = p.x - geometry.puller_offset_x;
  const double dz = p.z;
  depth_to_face = dx * ax + dz * az;
  // Right-pointing normal of the axis: (az, -ax).
  lateral = -(dx * az - dz * ax);
  heading = std::atan2(ax, az);
}

bool ApproachController::observeLine(const ApproachObservation& observation, const OdometryPose& odometry)
{
  const double c = std::cos(odometry.heading);
  const double s = std::sin(odometry.heading);
  const cv::Point3d& p = observation.position;
  AxisLine seen;
  seen.x = odometry.x + p.x * c + p.z * s;
  seen.z = odometry.z - p.x * s + p.z * c;
  const cv::Vec3d& a = observation.axis;
  // Without an axis yet the spool is taken as square to the camera.
  seen.heading =
      odometry.heading + (std::isfinite(a[0]) && std::isfinite(a[2]) && a[2] > 0.0 ? std::atan2(a[0], a[2]) : 0.0);
  if (!line_)
  {
    line_ = seen;
    return true;
  }
  if (std::hypot(seen.x - line_->x, seen.z - line_->z) > params_.max_line_jump)
    return false;
  const double m = params_.line_memory;
  line_->x = m * line_->x + (1.0 - m) * seen.x;
  line_->z = m * line_->z + (1.0 - m) * seen.z;
  line_->heading = m * line_->heading + (1.0 - m) * seen.heading;
  return true;
}

void ApproachController::lineErrors(const OdometryPose& odometry, double& lateral, double& heading,
                                    double& depth_to_face) const
{
  // The estimated line seen from the camera now.
  const cv::Point2d bore = boreInCamera(odometry);
  ApproachObservation seen;
  seen.position = {bore.x, 0.0, bore.y};
  const double relative = line_->heading - odometry.heading;
  seen.axis = {std::sin(relative), 0.0, std::cos(relative)};
  floorErrors(seen, geometry_, lateral, heading, depth_to_face);
}

cv::Point2d ApproachController::boreInCamera(const OdometryPose& odometry) const
{
  const double c = std::cos(odometry.heading);
  const double s = std::sin(odometry.heading);
  const double dx = line_->x - odometry.x;
  const double dz = line_->z - odometry.z;
  return {dx * c - dz * s, dx * s + dz * c};
}

bool ApproachController::errors(const OdometryPose& odometry, double& lateral, double& heading,
                                double& depth_to_go) const
{
  if (!line_)
    return false;
  double to_face = 0.0;
  lineErrors(odometry, lateral, heading, to_face);
  depth_to_go = to_face - params_.standoff_depth;
  return true;
}

ApproachCommand ApproachController::steer(const ApproachObservation& observation, const OdometryPose& odometry,
                                          double speed) const
{
  double lateral = 0.0;
  double heading = 0.0;
  double to_face = 0.0;
  lineErrors(odometry, lateral, heading, to_face);
  ApproachCommand command;
  command.speed = speed;
  // Turn onto the axis's direction, plus towards the axis point `lookahead` ahead. Turning in
  // place the puller is the turning point and its lateral error e stays; the push goes along the
  // heading, so aim through the bore instead: at the angle t that makes the misses at its front
  // (to_face ahead, e + to_face t) and at its back (bore_length_max further) equal and opposite,
  // t = -2 e / (2 to_face + bore_length_max), each then e bore_length_max / (2 to_face +
  // bore_length_max): a 3 mm error left at the end of a run-up misses by 0.5 mm, no back-off needed.
  // Reversing, the same line follower mirrored: the nose turns away from the axis so that the
  // back-off closes on it as well.
  double towards_axis = 0.0;
  if (speed > 0.0)
    towards_axis = std::atan(-lateral / params_.lookahead);
  else if (speed < 0.0)
    towards_axis = std::atan(lateral / params_.lookahead);
  else
    towards_axis = std::atan(-2.0 * lateral / (2.0 * std::max(to_face, 0.0) + geometry_.bore_length_max));
  // Keep the bore in view: turning right by t moves its bearing b (atan(x / z) in the camera
  // frame, right positive) to b - t.
  const cv::Point2d bore = boreInCamera(odometry);
  const double bearing = std::atan2(bore.x, bore.y);
  const double turn =
      std::clamp(heading + towards_axis, bearing - params_.max_bore_bearing, bearing + params_.max_bore_bearing);
  command.yaw_rate = std::clamp(params_.heading_gain * turn, -params_.max_yaw_rate, params_.max_yaw_rate);
  if (observation.detected && std::isfinite(observation.position.y))
    command.lift_rate = std::clamp(-params_.lift_gain * (observation.position.y - geometry_.puller_offset_y),
                                   -params_.max_lift_rate, params_.max_lift_rate);
  return command;
}

ApproachCommand ApproachController::approach(const ApproachObservation& observation, const OdometryPose& odometry)
{
  double lateral = 0.0;
  double heading = 0.0;
  double to_face = 0.0;
  lineErrors(odometry, lateral, heading, to_face);
  const double to_go = to_face - params_.standoff_depth;
  if (to_go <= params_.stop_tolerance)
  {
    phase_ = ApproachPhase::kHold;
    phase_time_ = 0.0;
    return steer(observation, odometry, 0.0);
  }
  return steer(observation, odometry, std::clamp(params_.slow_down * to_go, params_.min_speed, params_.max_speed));
}

ApproachCommand ApproachController::update(const ApproachObservation& observation, const OdometryPose& odometry,
                                           double dt)
{
  requirePositive(dt, "dt");
  phase_time_ += dt;
  const bool held = observation.detected && std::isfinite(observation.position.z);
  unseen_time_ = held ? 0.0 : unseen_time_ + dt;
  if (held && !observation.coasting)
    disagreements_ = observeLine(observation, odometry) ? 0 : disagreements_ + 1;
  ApproachCommand command;
  switch (phase_)
  {
    case ApproachPhase::kInsert:
    case ApproachPhase::kGaveUp:
      return command;
    case ApproachPhase::kBackOff:
      reversed_ += params_.backoff_speed * dt;
      if (reversed_ < params_.backoff_distance)
      {
        if (line_)
          return steer(observation, odometry, -params_.backoff_speed);
        command.speed = -params_.backoff_speed;
        return command;
      }
      ++retries_;
      phase_ = retries_ > params_.max_retries ? ApproachPhase::kGaveUp : ApproachPhase::kApproach;
      phase_time_ = 0.0;
      return command;
    case ApproachPhase::kApproach:
    case ApproachPhase::kHold:
      break;
  }
  if (held && observation.aligned && !observation.coasting && disagreements_ == 0)
  {
    phase_ = ApproachPhase::kInsert;
    command.insert = true;
    return command;
  }
  const bool timed_out = phase_ == ApproachPhase::kHold && phase_time_ > params_.hold_timeout;
  const bool disagreeing = disagreements_ >= params_.max_disagreements;
  if (timed_out || disagreeing || unseen_time_ > params_.lost_timeout)
  {
    if (disagreeing)
      line_.reset();  // the new run-up starts the estimate from the poses then
    disagreements_ = 0;
    phase_ = ApproachPhase::kBackOff;
    phase_time_ = 0.0;
    reversed_ = 0.0;
    return command;
  }
  if (!line_ || !held)
    return command;  // stand still until the spool is held again
  if (phase_ == ApproachPhase::kHold)
    return steer(observation, odometry, 0.0);
  return approach(observation, odometry);
}

}  // namespace spool_vision
