// The lens model of a raw webcam frame: OpenCV's (which is ROS's plumb_bob and
// rational_polynomial), used to undistort the edges the detector measures and to map measured
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

/// distortPixel()'s inverse: where a raw frame's pixel `p` lies in the undistorted image with the
/// same K (px), by cv::undistortPoints (20 iterations, as undistortionTable()). Returns `p`
/// unchanged when the camera has no distortion.
cv::Point2d undistortPixel(const CameraIntrinsics& camera, const cv::Point2d& p);

/// px between the nodes at which undistortionTable() solves the lens model exactly.
constexpr int kUndistortionGridStep = 8;

/// For every pixel of `camera`'s raw frame, where it lies in the undistorted image with the same
/// K (CV_32FC2, height x width, px): cv::undistortPoints at every kUndistortionGridStep-th pixel
/// in x and y, Catmull-Rom in between (within 0.001 px of solving every pixel, for a C270-like
/// lens and a strong rational_polynomial one; about 5 ms at 1280x720 where every pixel's solve
/// took 320). Throws std::invalid_argument when the camera is invalid.
void undistortionTable(const CameraIntrinsics& camera, cv::Mat& table);

}  // namespace spool_vision
