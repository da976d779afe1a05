// The lens model of a raw webcam frame: OpenCV's (which is ROS's plumb_bob and
// rational_polynomial), used to undistort a frame before it is measured and to map measured
// points back into the frame a user sees.
#pragma once

#include <opencv2/core.hpp>

#include "spool_vision/types.h"

namespace spool_vision
{
/// Where an undistorted pixel `p` of `camera` (the ideal pinhole image with the same K) appears
/// in the raw, distorted frame (px). OpenCV's model (calib3d "Camera Calibration and 3D
/// Reconstruction": x'' = x' (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6) +
/// 2 p1 x' y' + p2 (r^2 + 2 x'^2), likewise y''), written out because cv::projectPoints allocates
/// on every call. Returns `p` unchanged when the camera has no distortion.
cv::Point2d distortPixel(const CameraIntrinsics& camera, const cv::Point2d& p);

/// Fixed-point maps (cv::remap, CV_16SC2 + CV_16UC1) from the raw frame of `camera` to its
/// undistorted image with the same K (cv::initUndistortRectifyMap). Throws
/// std::invalid_argument when the camera is invalid.
void undistortionMaps(const CameraIntrinsics& camera, cv::Mat& map1, cv::Mat& map2);

}  // namespace spool_vision
