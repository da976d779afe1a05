#include "pose_conversion.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace spool_vision
{
namespace
{
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool finite(const cv::Vec3d& v)
{
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

}  // namespace

SpoolPose toSpoolPose(const SpoolDetection& detection, const std_msgs::Header& header)
{
  const bool detected = detection.detected;
  SpoolPose pose;
  pose.header = header;
  pose.detected = detected;
  pose.hole_detected = detected && detection.hole_detected;
  pose.overlapped = detection.overlapped;
  pose.aligned = detection.aligned;
  pose.distance = detected ? detection.distance : kNaN;
  pose.range = detected ? detection.range : kNaN;
  pose.yaw = detected ? detection.yaw : kNaN;
  pose.lateral_offset = detected ? detection.lateral_offset : kNaN;
  pose.tolerance = detection.tolerance;
  pose.position.x = detected ? detection.position.x : kNaN;
  pose.position.y = detected ? detection.position.y : kNaN;
  pose.position.z = detected ? detection.position.z : kNaN;
  pose.axis.x = detected ? detection.axis[0] : kNaN;
  pose.axis.y = detected ? detection.axis[1] : kNaN;
  pose.axis.z = detected ? detection.axis[2] : kNaN;
  pose.axis_angle = detected ? detection.axis_angle : kNaN;
  pose.axis_yaw = detected ? detection.axis_yaw : kNaN;
  pose.bore_see_through = pose.hole_detected && detection.lens_detected;
  // A coasting track's frame has no rims of its own (their radius is 0).
  const bool flange = detected && detection.flange.r > 0.0;
  pose.flange_x = flange ? detection.flange.x : kNaN;
  pose.flange_y = flange ? detection.flange.y : kNaN;
  pose.flange_radius = flange ? detection.flange.r : kNaN;
  pose.hole_x = pose.hole_detected ? detection.hole.x : kNaN;
  pose.hole_y = pose.hole_detected ? detection.hole.y : kNaN;
  pose.hole_radius = pose.hole_detected ? detection.hole.r : kNaN;
  pose.reference_x = detection.reference.x;
  pose.reference_y = detection.reference.y;
  pose.confidence = detected ? detection.confidence : 0.0;
  setTrackFields(pose, nullptr);
  return pose;
}

static_assert(static_cast<std::uint8_t>(AxisCue::kNone) == SpoolPose::AXIS_CUE_NONE &&
                  static_cast<std::uint8_t>(AxisCue::kRim) == SpoolPose::AXIS_CUE_RIM &&
                  static_cast<std::uint8_t>(AxisCue::kBoreParallax) == SpoolPose::AXIS_CUE_BORE_PARALLAX,
              "AxisCue's values are the message's AXIS_CUE_* constants");

void setTrackFields(SpoolPose& pose, const TrackedFrame* frame)
{
  if (!frame)
  {
    pose.track_state = SpoolPose::TRACK_OFF;
    pose.track_age = 0;
    pose.track_rejected = 0;
    pose.raw_distance = pose.distance;
    pose.position_covariance.fill(kNaN);
    pose.axis_cue = static_cast<std::uint8_t>(std::isfinite(pose.axis.z) ? AxisCue::kRim : AxisCue::kNone);
    pose.axis_sigma = kNaN;
    return;
  }
  const TrackedSpool& t = frame->track;
  pose.track_state = static_cast<std::uint8_t>(t.state);
  pose.track_age = static_cast<std::uint32_t>(t.age);
  pose.track_rejected = static_cast<std::uint32_t>(t.rejected);
  pose.raw_distance = frame->raw.detected ? frame->raw.distance : kNaN;
  for (int i = 0; i < 9; ++i)
    pose.position_covariance[i] = frame->published.detected ? t.position_covariance(i / 3, i % 3) : kNaN;
  const bool axis = frame->published.detected && std::isfinite(t.axis_sigma);
  pose.axis_cue = static_cast<std::uint8_t>(axis ? t.axis_cue : AxisCue::kNone);
  pose.axis_sigma = axis ? t.axis_sigma : kNaN;
}

std::optional<geometry_msgs::PoseWithCovarianceStamped> poseWithCovariance(const TrackedFrame& frame,
                                                                           const std_msgs::Header& header)
{
  const std::optional<geometry_msgs::Pose> pose = spoolPose3d(frame.published);
  if (!pose)
    return std::nullopt;
  geometry_msgs::PoseWithCovarianceStamped out;
  out.header = header;
  out.pose.pose = *pose;
  out.pose.covariance.fill(0.0);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      out.pose.covariance[static_cast<std::size_t>(r) * 6 + static_cast<std::size_t>(c)] =
          frame.track.position_covariance(r, c);
  const double tilt =
      std::isfinite(frame.track.axis_sigma) ? frame.track.axis_sigma * frame.track.axis_sigma : kUnobservedVariance;
  out.pose.covariance[21] = tilt;                 // about x
  out.pose.covariance[28] = tilt;                 // about y
  out.pose.covariance[35] = kUnobservedVariance;  // about the spool axis: a circle shows none
  return out;
}

SpoolPose undefinedSpoolPose(const std_msgs::Header& header, double tolerance)
{
  SpoolDetection nothing;
  nothing.tolerance = tolerance;
  nothing.reference = cv::Point2d(kNaN, kNaN);
  return toSpoolPose(nothing, header);
}

std::optional<geometry_msgs::Pose> spoolPose3d(const SpoolDetection& detection)
{
  const cv::Vec3d position(detection.position.x, detection.position.y, detection.position.z);
  if (!detection.detected || !finite(position) || !finite(detection.axis) || cv::norm(detection.axis) == 0.0)
    return std::nullopt;
  const cv::Vec3d z = cv::normalize(detection.axis);
  // x level: perpendicular to z and to the camera's y (down). An axis along y (a spool seen from
  // straight above or below, which the detector does not report) keeps the camera's x.
  cv::Vec3d x(z[2], 0.0, -z[0]);
  x = cv::norm(x) > 1e-9 ? cv::normalize(x) : cv::Vec3d(1.0, 0.0, 0.0);
  const cv::Vec3d y = z.cross(x);

  // Rotation matrix columns x, y, z -> quaternion (Shepperd's method, the largest term first
  // for accuracy).
  const double m00 = x[0], m01 = y[0], m02 = z[0];
  const double m10 = x[1], m11 = y[1], m12 = z[1];
  const double m20 = x[2], m21 = y[2], m22 = z[2];
  geometry_msgs::Pose pose;
  auto& q = pose.orientation;
  const double trace = m00 + m11 + m22;
  if (trace > 0.0)
  {
    const double s = 2.0 * std::sqrt(1.0 + trace);
    q.w = 0.25 * s;
    q.x = (m21 - m12) / s;
    q.y = (m02 - m20) / s;
    q.z = (m10 - m01) / s;
  }
  else if (m00 > m11 && m00 > m22)
  {
    const double s = 2.0 * std::sqrt(1.0 + m00 - m11 - m22);
    q.w = (m21 - m12) / s;
    q.x = 0.25 * s;
    q.y = (m01 + m10) / s;
    q.z = (m02 + m20) / s;
  }
  else if (m11 > m22)
  {
    const double s = 2.0 * std::sqrt(1.0 + m11 - m00 - m22);
    q.w = (m02 - m20) / s;
    q.x = (m01 + m10) / s;
    q.y = 0.25 * s;
    q.z = (m12 + m21) / s;
  }
  else
  {
    const double s = 2.0 * std::sqrt(1.0 + m22 - m00 - m11);
    q.w = (m10 - m01) / s;
    q.x = (m02 + m20) / s;
    q.y = (m12 + m21) / s;
    q.z = 0.25 * s;
  }
  pose.position.x = position[0];
  pose.position.y = position[1];
  pose.position.z = position[2];
  return pose;
}

visualization_msgs::Marker spoolMarker(const std_msgs::Header& header, const std::optional<geometry_msgs::Pose>& pose,
                                       double flange_diameter, double hub_length)
{
  visualization_msgs::Marker marker;
  marker.header = header;
  marker.ns = "spool";
  marker.id = 0;
  if (!pose)
  {
    marker.action = visualization_msgs::Marker::DELETE;
    marker.pose.orientation.w = 1.0;
    return marker;
  }
  marker.action = visualization_msgs::Marker::ADD;
  marker.type = visualization_msgs::Marker::CYLINDER;
  // RViz centres a cylinder on its pose with its height along z: move it half a hub into the
  // spool so that its front face lies on the bore's front centre.
  marker.pose = *pose;
  const auto& q = pose->orientation;
  const double zx = 2.0 * (q.x * q.z + q.w * q.y);
  const double zy = 2.0 * (q.y * q.z - q.w * q.x);
  const double zz = 1.0 - 2.0 * (q.x * q.x + q.y * q.y);
  marker.pose.position.x += 0.5 * hub_length * zx;
  marker.pose.position.y += 0.5 * hub_length * zy;
  marker.pose.position.z += 0.5 * hub_length * zz;
  marker.scale.x = marker.scale.y = flange_diameter;
  marker.scale.z = hub_length;
  // Copper winding between black flanges: copper, slightly see-through so the image shows.
  marker.color.r = 0.72f;
  marker.color.g = 0.45f;
  marker.color.b = 0.2f;
  marker.color.a = 0.8f;
  return marker;
}

CameraMotion toCameraMotion(const geometry_msgs::Transform& transform)
{
  const Eigen::Quaterniond q(transform.rotation.w, transform.rotation.x, transform.rotation.y, transform.rotation.z);
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  CameraMotion motion;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      motion.rotation(i, j) = r(i, j);
  motion.translation = {transform.translation.x, transform.translation.y, transform.translation.z};
  return motion;
}

}  // namespace spool_vision
