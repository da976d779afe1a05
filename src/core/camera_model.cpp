#include "spool_vision/camera_model.h"

#include <stdexcept>

#include <opencv2/calib3d.hpp>

namespace spool_vision
{
cv::Point2d distortPixel(const CameraIntrinsics& camera, const cv::Point2d& p)
{
  if (!camera.distorted())
    return p;
  const auto& d = camera.distortion;
  auto k = [&d](std::size_t i) { return i < d.size() ? d[i] : 0.0; };
  const double x = (p.x - camera.cx) / camera.fx;
  const double y = (p.y - camera.cy) / camera.fy;
  const double r2 = x * x + y * y;
  const double radial = (1.0 + r2 * (k(0) + r2 * (k(1) + r2 * k(4)))) / (1.0 + r2 * (k(5) + r2 * (k(6) + r2 * k(7))));
  const double xd = x * radial + 2.0 * k(2) * x * y + k(3) * (r2 + 2.0 * x * x);
  const double yd = y * radial + k(2) * (r2 + 2.0 * y * y) + 2.0 * k(3) * x * y;
  return {camera.cx + camera.fx * xd, camera.cy + camera.fy * yd};
}

void undistortionTable(const CameraIntrinsics& camera, cv::Mat& table)
{
  if (!camera.valid())
    throw std::invalid_argument("undistortionTable: invalid camera intrinsics");
  const cv::Matx33d k(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  cv::Mat raw(camera.height, camera.width, CV_32FC2);
  for (int y = 0; y < raw.rows; ++y)
    for (int x = 0; x < raw.cols; ++x)
      raw.at<cv::Vec2f>(y, x) = cv::Vec2f(static_cast<float>(x), static_cast<float>(y));
  // Iterative inversion of the model (20 steps: the default 5 leave ~0.01 px at a C270's corners);
  // P = K keeps the undistorted image's scale.
  cv::undistortPoints(raw.reshape(2, raw.rows * raw.cols), table, k, camera.distortion, cv::noArray(), k,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0.0));
  table = table.reshape(2, camera.height);
}

}  // namespace spool_vision
