// SpoolDetection (ROS-free core) -> spool_vision/SpoolPose (REP 103 units, NaN when undefined).
#pragma once

#include <std_msgs/Header.h>

#include "spool_vision/SpoolPose.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// The message for one processed frame; `header` is the input image's header.
SpoolPose toSpoolPose(const SpoolDetection& detection, const std_msgs::Header& header);

/// The message for a frame that could not be processed: nothing detected, every number NaN
/// except the tolerance, which does not depend on the frame.
SpoolPose undefinedSpoolPose(const std_msgs::Header& header, double tolerance);

}  // namespace spool_vision
