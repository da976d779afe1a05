// Reading parameter YAML files and ROS camera-calibration YAML files without ROS.
#pragma once

#include <string>

#include "spool_vision/detector_params.h"
#include "spool_vision/types.h"

namespace spool_vision
{
/// Loads a flat parameter YAML (the format of config/*.yaml) on top of `params`. Unknown keys,
/// wrong types and out-of-range values throw ParamError naming the key; an unreadable or
/// malformed file throws std::runtime_error.
void loadParamsYaml(const std::string& path, DetectorParams& params);

/// Writes every key of `params` with its unit and allowed range as comments.
std::string paramsToYaml(const DetectorParams& params);

/// Reads a camera-calibration YAML (camera_calibration / camera_info_manager format:
/// image_width, image_height, camera_matrix, distortion_model, distortion_coefficients,
/// projection_matrix) as image_geometry reads a camera_info: with non-zero distortion (plumb_bob
/// or rational_polynomial) the raw image's K and D; without, the rectified image's P (K when
/// there is no projection_matrix). Throws std::runtime_error naming the file and the problem
/// (another distortion model, a matrix of the wrong size, an uncalibrated all-zero matrix).
CameraIntrinsics loadCameraInfoYaml(const std::string& path);

/// Writes intrinsics in that format (their distortion, identity rectification, P = K).
std::string cameraInfoToYaml(const CameraIntrinsics& camera, const std::string& camera_name);

/// Writes cameraInfoToYaml() to `path`. Throws std::runtime_error when it cannot.
void saveCameraInfoYaml(const std::string& path, const CameraIntrinsics& camera, const std::string& camera_name);

}  // namespace spool_vision
