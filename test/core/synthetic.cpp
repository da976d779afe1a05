#include "synthetic.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace spool_vision::test
{
namespace
{
constexpr int kSuper = 8;  // sub-samples per pixel side on the boundary
}  // namespace

// cv::circle's anti-aliased discs come out ~0.6 px larger than asked, which would bias every
// expected radius; this one blends by exact area coverage.
void fillEllipse(cv::Mat& gray, double x, double y, double a, double b, int value, double tilt)
{
  const double c = std::cos(tilt);
  const double s = std::sin(tilt);
  const double half_w = std::hypot(a * c, b * s);
  const double half_h = std::hypot(a * s, b * c);
  const int x0 = std::max(0, static_cast<int>(std::floor(x - half_w - 1)));
  const int x1 = std::min(gray.cols - 1, static_cast<int>(std::ceil(x + half_w + 1)));
  const int y0 = std::max(0, static_cast<int>(std::floor(y - half_h - 1)));
  const int y1 = std::min(gray.rows - 1, static_cast<int>(std::ceil(y + half_h + 1)));
  const double band = 1.0 / std::min(a, b);  // about one pixel in normalised radius
  // Normalised radius of the point (px, py): 1 on the ellipse.
  auto rho = [&](double px, double py)
  { return std::hypot((c * (px - x) + s * (py - y)) / a, (c * (py - y) - s * (px - x)) / b); };
  for (int py = y0; py <= y1; ++py)
  {
    uchar* row = gray.ptr<uchar>(py);
    for (int px = x0; px <= x1; ++px)
    {
      const double at = rho(px, py);
      double cover = at < 1.0 - band ? 1.0 : 0.0;
      if (std::abs(at - 1.0) <= band)
      {
        int inside = 0;
        for (int i = 0; i < kSuper; ++i)
          for (int j = 0; j < kSuper; ++j)
            inside += rho(px - 0.5 + (i + 0.5) / kSuper, py - 0.5 + (j + 0.5) / kSuper) <= 1.0 ? 1 : 0;
        cover = static_cast<double>(inside) / (kSuper * kSuper);
      }
      if (cover > 0.0)
        row[px] = cv::saturate_cast<uchar>(cover * value + (1.0 - cover) * row[px]);
    }
  }
}

DrawnSpool spoolAt(const CameraIntrinsics& camera, double depth, double lateral, double below)
{
  return {camera.cx + camera.fx * lateral / depth, camera.cy + camera.fy * below / depth, camera.fy * 0.175 / depth,
          camera.fy * 0.018 / depth};
}

cv::Mat drawSceneGray(cv::Size size, const std::vector<DrawnSpool>& spools, const SceneStyle& style)
{
  cv::Mat img(size, CV_8UC1, cv::Scalar::all(style.background));
  for (const auto& s : spools)
  {
    fillEllipse(img, s.x, s.y, s.flange_r, s.flange_r, style.flange);
    if (s.hole_r > 0)
      fillEllipse(img, s.x, s.y, s.hole_r, s.hole_r, style.hole);
  }
  if (style.noise_sigma > 0)
  {
    cv::Mat noise(size, CV_16SC1);
    cv::RNG rng(style.seed);
    rng.fill(noise, cv::RNG::NORMAL, 0, style.noise_sigma);
    cv::Mat wide;
    img.convertTo(wide, CV_16SC1);
    wide += noise;
    wide.convertTo(img, CV_8UC1);
  }
  return img;
}

cv::Mat drawScene(cv::Size size, const std::vector<DrawnSpool>& spools, const SceneStyle& style)
{
  cv::Mat bgr;
  cv::cvtColor(drawSceneGray(size, spools, style), bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace spool_vision::test
