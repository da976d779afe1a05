// sensor_msgs/CameraInfo -> spool_vision::CameraIntrinsics (the core's ROS-free camera), read as
// image_geometry::PinholeCameraModel reads it. Pure: no master, no logging (the adapter logs).
#pragma once

#include <optional>
#include <string>

#include <sensor_msgs/CameraInfo.h>

#include "spool_vision/types.h"

namespace spool_vision
{
/// What a camera_info says about the image it came with.
struct CameraInfoConversion
{
  /// The intrinsics of that image (its size); empty: the thesis fallback applies, see `problem`.
  std::optional<CameraIntrinsics> camera;
  /// Why `camera` is empty; names the fix where there is one.
  std::string problem;
  /// The camera_info is usable in principle but was refused (an unsupported distortion model, a
  /// size of another aspect ratio): an error, where an uncalibrated camera is only a warning.
  bool refused = false;
  /// Set when the calibration was made for another size of the same aspect ratio and was scaled.
  std::string scaled;
  /// Set when the image is taken for rectified but the camera_info has a non-zero D: D is not
  /// applied again (image_proc publishes image_rect beside the raw camera_info, so that is the
  /// normal pipeline, and undistorting twice would bend every rim), and the text says which
  /// matrix describes the image and how to say the image is raw after all.
  std::string distortion_ignored;
};

/// Reads `info` for an image of image_width x image_height:
/// - K all zero (an uncalibrated camera_info_manager): no camera;
/// - `rectified` (the image is image_proc's image_rect, published beside the raw camera_info and
///   its D) or D all zero or empty: the image is rectified or undistorted, described by P (K
///   when P is unset); no distortion (a non-zero D is then reported in `distortion_ignored`);
/// - otherwise a raw image: K with D, plumb_bob (5 coefficients) or rational_polynomial (8);
///   other models (equidistant, ...) are refused;
/// - binning and ROI as PinholeCameraModel applies them (principal point shifted by the ROI
///   offset, then fx, cx divided by binning_x and fy, cy by binning_y); the image is then
///   expected to be the ROI's size divided by the binning;
/// - an image of another size with the same aspect ratio (within 1%): the calibrated image
///   resized, fx, cx scaled by the width ratio and fy, cy by the height ratio (pixel centres:
///   c' = (c + 0.5) s - 0.5); another aspect ratio (a crop or another sensor mode) is refused.
CameraInfoConversion cameraFromInfo(const sensor_msgs::CameraInfo& info, int image_width, int image_height,
                                    bool rectified = false);

/// The `rectified` key: "true", "false", or "auto", which takes an image topic whose last name
/// starts with image_rect (image_proc's image_rect, image_rect_color) for rectified. Throws
/// ParamError on another value.
bool isRectifiedStream(const std::string& setting, const std::string& image_topic);

/// spool_vision::CameraIntrinsics -> sensor_msgs/CameraInfo of the raw image (the inverse of
/// cameraFromInfo for a raw stream): K, D as plumb_bob (4 coefficients padded to 5; none: five
/// zeros) or rational_polynomial (8), R identity, P = [K | 0]; no binning, no ROI. The header is
/// left to the caller.
sensor_msgs::CameraInfo infoFromCamera(const CameraIntrinsics& camera);

/// True when `a` and `b` describe the same camera (every field but the header).
bool sameCalibration(const sensor_msgs::CameraInfo& a, const sensor_msgs::CameraInfo& b);

}  // namespace spool_vision
