#include "pose_conversion.h"

#include <limits>

namespace spool_vision
{
namespace
{
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

SpoolPose toSpoolPose(const SpoolDetection& detection, const std_msgs::Header& header)
{
  SpoolPose pose;
  pose.header = header;
  pose.detected = detection.detected;
  pose.hole_detected = detection.detected && detection.hole_detected;
  pose.overlapped = detection.overlapped;
  pose.aligned = detection.aligned;
  pose.distance = detection.detected ? detection.distance : kNaN;
  pose.yaw = detection.detected ? detection.yaw : kNaN;
  pose.lateral_offset = detection.detected ? detection.lateral_offset : kNaN;
  pose.tolerance = detection.tolerance;
  pose.flange_x = detection.detected ? detection.flange.x : kNaN;
  pose.flange_y = detection.detected ? detection.flange.y : kNaN;
  pose.flange_radius = detection.detected ? detection.flange.r : kNaN;
  pose.hole_x = pose.hole_detected ? detection.hole.x : kNaN;
  pose.hole_y = pose.hole_detected ? detection.hole.y : kNaN;
  pose.hole_radius = pose.hole_detected ? detection.hole.r : kNaN;
  pose.reference_x = detection.reference.x;
  pose.reference_y = detection.reference.y;
  pose.confidence = detection.detected ? detection.confidence : 0.0;
  return pose;
}

SpoolPose undefinedSpoolPose(const std_msgs::Header& header, double tolerance)
{
  SpoolDetection nothing;
  nothing.tolerance = tolerance;
  nothing.reference = cv::Point2d(kNaN, kNaN);
  return toSpoolPose(nothing, header);
}

}  // namespace spool_vision
