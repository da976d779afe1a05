// Detector parameters from the ROS parameter server: the node reads its private namespace by
// walking spool_vision::paramSpecs(), so each key is checked exactly as the CLI checks the YAML.
#pragma once

#include <set>
#include <string>

#include <ros/node_handle.h>

#include "spool_vision/detector_params.h"

namespace spool_vision
{
/// Reads every detector key present in `pnh` on top of `params` and validates the result.
/// A private key that is neither a detector key nor in `ros_keys` is rejected too, so a typo in
/// a launch or YAML file stops the node instead of being ignored. Throws ParamError.
void loadParamsFromRos(const ros::NodeHandle& pnh, const std::set<std::string>& ros_keys, DetectorParams& params);

/// Why node `node_name` refuses to start, and for a bad parameter how to fix it: a value left on
/// the parameter server by an earlier run blocks every later plain start until it is deleted.
std::string refusalMessage(const std::string& node_name, const std::exception& error);

/// Writes `value` to `pnh` under `key` with its natural XML-RPC type.
void setRosParam(const ros::NodeHandle& pnh, const std::string& key, const ParamValue& value);

}  // namespace spool_vision
