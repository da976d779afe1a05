// SpoolDetection (ROS-free core) -> spool_vision/SpoolPose, geometry_msgs/PoseStamped and an RViz
// marker (REP 103 units, NaN when undefined).
#pragma once

#include <optional>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Transform.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/Marker.h>

#include "spool_vision/SpoolPose.h"
#include "spool_vision/spool_tracker.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// The message for one processed frame; `header` is the input image's header.
SpoolPose toSpoolPose(const SpoolDetection& detection, const std_msgs::Header& header);

/// The message for a frame that could not be processed: nothing detected, every number NaN
/// except the tolerance, which does not depend on the frame.
SpoolPose undefinedSpoolPose(const std_msgs::Header& header, double tolerance);

/// The spool as a pose in the camera optical frame: origin at the bore's front centre, z along
/// the spool axis into the spool, x level (in the camera's x-z plane, towards the camera's right
/// when the spool faces the camera) and y = z cross x (down when level). Empty when nothing was
/// detected or the position or axis is not finite (not measured).
std::optional<geometry_msgs::Pose> spoolPose3d(const SpoolDetection& detection);

/// The tracker's fields of `pose` (track_state, track_age, track_rejected, raw_distance,
/// position_covariance) for `frame`; without one (~track false) TRACK_OFF, age 0, raw_distance
/// the published depth and the covariance NaN.
void setTrackFields(SpoolPose& pose, const TrackedFrame* frame);

/// Variance given to what a frame does not observe (the rotation about the spool axis; the axis
/// before a hole rim gave one), as ROS consumers of PoseWithCovariance expect: large, not zero.
constexpr double kUnobservedVariance = 1e6;

/// The tracked spool as geometry_msgs/PoseWithCovarianceStamped: spoolPose3d() of the published
/// (filtered) detection, covariance 6x6 row-major in the camera optical frame (x, y, z, then
/// rotations about x, y, z): the position block the tracker's; rotations about x and y the
/// axis's variance (axis_sigma^2, small angles), about z kUnobservedVariance. Empty when no
/// track holds the spool or its pose is not measured.
std::optional<geometry_msgs::PoseWithCovarianceStamped> poseWithCovariance(const TrackedFrame& frame,
                                                                           const std_msgs::Header& header);

/// The spool for RViz: a CYLINDER of the flange's diameter and the hub's length whose front face
/// is centred on the bore's front centre and which extends along the axis into the spool
/// (namespace "spool", id 0). Without a pose: a DELETE of that marker, so that RViz never shows a
/// spool that is no longer seen.
visualization_msgs::Marker spoolMarker(const std_msgs::Header& header, const std::optional<geometry_msgs::Pose>& pose,
                                       double flange_diameter, double hub_length);

/// The tracker's CameraMotion from a TF transform of the camera frame at one stamp to itself at an
/// earlier one (tf2_ros::Buffer::lookupTransform(camera, now, camera, before, odom)): it maps a
/// point's coordinates in the earlier camera frame to the later one's, which is CameraMotion's
/// meaning. The quaternion is normalised (TF accepts any length).
CameraMotion toCameraMotion(const geometry_msgs::Transform& transform);

}  // namespace spool_vision
