#include "spool_vision/camera_model.h"

#include <array>
#include <stdexcept>
#include <vector>

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

namespace
{
// Catmull-Rom weights of the four nodes around a point t (0..1) of the way from the second to the
// third: exact for cubics, so a smooth map sampled every few px is interpolated to a small
// fraction of what bilinear interpolation leaves.
std::array<float, 4> cubicWeights(float t)
{
  const float t2 = t * t;
  const float t3 = t2 * t;
  return {0.5f * (-t3 + 2.0f * t2 - t), 0.5f * (3.0f * t3 - 5.0f * t2 + 2.0f), 0.5f * (-3.0f * t3 + 4.0f * t2 + t),
          0.5f * (t3 - t2)};
}
}  // namespace

cv::Point2d undistortPixel(const CameraIntrinsics& camera, const cv::Point2d& p)
{
  if (!camera.distorted())
    return p;
  const cv::Matx33d k(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  std::vector<cv::Point2d> raw{p};
  std::vector<cv::Point2d> ideal;
  cv::undistortPoints(raw, ideal, k, camera.distortion, cv::noArray(), k,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0.0));
  return ideal.front();
}

void undistortionTable(const CameraIntrinsics& camera, cv::Mat& table)
{
  if (!camera.valid())
    throw std::invalid_argument("undistortionTable: invalid camera intrinsics");
  const cv::Matx33d k(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  // The lens model's inverse is smooth: it is solved on the nodes of a grid kUndistortionGridStep
  // px apart, one node before the frame and two past it in each direction, and interpolated
  // (Catmull-Rom, separably) in between: a 64th of the solves of every pixel's (320 ms at 1280x720).
  constexpr int step = kUndistortionGridStep;
  const int nodes_x = (camera.width - 1) / step + 4;
  const int nodes_y = (camera.height - 1) / step + 4;
  cv::Mat raw(nodes_y * nodes_x, 1, CV_32FC2);
  for (int j = 0; j < nodes_y; ++j)
    for (int i = 0; i < nodes_x; ++i)
      raw.at<cv::Vec2f>(j * nodes_x + i) =
          cv::Vec2f(static_cast<float>((i - 1) * step), static_cast<float>((j - 1) * step));
  // Iterative inversion of the model (20 steps: the default 5 leave ~0.01 px at a C270's corners);
  // P = K keeps the undistorted image's scale.
  cv::Mat grid;
  cv::undistortPoints(raw, grid, k, camera.distortion, cv::noArray(), k,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0.0));
  grid = grid.reshape(2, nodes_y);
  std::array<std::array<float, 4>, step> weights;
  for (int o = 0; o < step; ++o)
    weights[static_cast<std::size_t>(o)] = cubicWeights(static_cast<float>(o) / step);
  table.create(camera.height, camera.width, CV_32FC2);
  std::vector<cv::Vec2f> column(static_cast<std::size_t>(nodes_x));  // this row, at every node column
  for (int y = 0; y < camera.height; ++y)
  {
    const int j = y / step;  // node row j + 1 is at or above y
    const std::array<float, 4>& wy = weights[static_cast<std::size_t>(y - j * step)];
    for (int i = 0; i < nodes_x; ++i)
    {
      cv::Vec2f sum(0.0f, 0.0f);
      for (int n = 0; n < 4; ++n)
        sum += wy[static_cast<std::size_t>(n)] * grid.ptr<cv::Vec2f>(j + n)[i];
      column[static_cast<std::size_t>(i)] = sum;
    }
    cv::Vec2f* out = table.ptr<cv::Vec2f>(y);
    for (int x = 0; x < camera.width; ++x)
    {
      const int i = x / step;
      const std::array<float, 4>& wx = weights[static_cast<std::size_t>(x - i * step)];
      const cv::Vec2f* c = &column[static_cast<std::size_t>(i)];
      out[x] = wx[0] * c[0] + wx[1] * c[1] + wx[2] * c[2] + wx[3] * c[3];
    }
  }
}

}  // namespace spool_vision
