#include "spool_vision/sim/forklift.h"

#include <algorithm>
#include <cmath>

namespace spool_vision
{
namespace
{
/// `target` reached from `current` at most `max_change` away, within +-`limit`.
double limited(double target, double current, double max_change, double limit)
{
  return std::clamp(std::clamp(target, current - max_change, current + max_change), -limit, limit);
}
}  // namespace

Forklift::Forklift(const ForkliftState& start, const ForkliftLimits& limits, const ActuationError& error,
                   std::uint64_t seed)
  : state_(start), limits_(limits), error_(error), rng_(seed)
{
}

void Forklift::step(const ApproachCommand& command, double dt)
{
  // The rate the drive reaches within its acceleration limit, then what the wheels make of it.
  const double speed =
      limited(command.speed * error_.speed_scale, state_.speed, limits_.max_acceleration * dt, limits_.max_speed) *
      (1.0 + error_.noise * rng_.gaussian(1.0));
  const double yaw_rate = limited(command.yaw_rate * error_.yaw_rate_scale, state_.yaw_rate,
                                  limits_.max_yaw_acceleration * dt, limits_.max_yaw_rate) *
                          (1.0 + error_.noise * rng_.gaussian(1.0));
  const double lift_rate = std::clamp(command.lift_rate, -limits_.max_lift_rate, limits_.max_lift_rate) *
                           error_.lift_scale * (1.0 + error_.noise * rng_.gaussian(1.0));
  // Midpoint heading: exact for a constant turn to second order.
  const double heading = state_.heading + 0.5 * yaw_rate * dt;
  state_.x += speed * dt * std::sin(heading);
  state_.depth -= speed * dt * std::cos(heading);
  state_.heading += yaw_rate * dt;
  state_.lift += lift_rate * dt;
  const double turned = yaw_rate * dt * error_.gyro_scale;
  const double odometry_heading = odometry_.heading + 0.5 * turned;
  odometry_.x += speed * dt * error_.odometry_scale * std::sin(odometry_heading);
  odometry_.z += speed * dt * error_.odometry_scale * std::cos(odometry_heading);
  odometry_.heading += turned;
  state_.speed = speed;
  state_.yaw_rate = yaw_rate;
}

CameraPose Forklift::cameraPose() const
{
  CameraPose pose;
  pose.lateral = state_.x;
  pose.height = state_.lift;
  pose.yaw = state_.heading;
  pose.pitch = 0.0;
  pose.distance = std::sqrt(state_.depth * state_.depth + state_.x * state_.x + state_.lift * state_.lift);
  return pose;
}

CameraMotion cameraMotion(const OdometryPose& from, const OdometryPose& to)
{
  // A point W of the floor plane (x right, z forward at the start) is at R(heading) (W - C) in
  // the camera at C, R(a) = [[cos a, -sin a], [sin a, cos a]] on (x, z). So from the earlier
  // camera to the later one: R(to - from) and R(to.heading) (C_from - C_to).
  const double turn = to.heading - from.heading;
  const double c = std::cos(turn);
  const double s = std::sin(turn);
  const double ch = std::cos(to.heading);
  const double sh = std::sin(to.heading);
  const double dx = from.x - to.x;
  const double dz = from.z - to.z;
  CameraMotion motion;
  motion.rotation = cv::Matx33d(c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c);
  motion.translation = {ch * dx - sh * dz, 0.0, sh * dx + ch * dz};
  return motion;
}

}  // namespace spool_vision
