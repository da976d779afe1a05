#include "spool_vision/bore_parallax.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "spool_vision/camera_model.h"

namespace spool_vision
{
namespace
{
// The disc read inside the rim: its blur spreads about a pixel plus a few % of its size.
double lensMargin(double radius)
{
  return 1.0 + 0.05 * radius;
}

// The segment of a circle of radius r beyond a chord at signed distance a from its centre:
// area, and its centroid's distance from the centre along the chord's normal.
void segment(double r, double a, double half_chord, double& area, double& offset)
{
  area = r * r * std::acos(std::clamp(a / r, -1.0, 1.0)) - a * half_chord;
  offset = area > 0.0 ? 2.0 * half_chord * half_chord * half_chord / (3.0 * area) : a;
}

struct Inputs
{
  cv::Point2d lens;   // the measured centroid, px
  cv::Point2d front;  // the front opening's centre, px
  double length;      // the bore, m
};

struct Solution
{
  cv::Vec2d slopes;   // the axis's x/z and y/z
  cv::Point2d back;   // the back opening's image centre, px
  double area = 0.0;  // the model's lit area there, px^2
};

// The back opening's image centre that puts the lens's centroid at `in.lens` (Newton from
// `start`, or from where an axis along the optical axis puts it), then the axis's slopes.
std::optional<Solution> solve(const Inputs& in, const GeometryParams& geometry, const CameraIntrinsics& camera,
                              double depth, const LensView& view, const std::optional<cv::Point2d>& start)
{
  const double bore_radius = 0.5 * geometry.hole_diameter;
  const double back_radius = camera.fy * bore_radius / (depth + in.length);
  // The lens seen is the measured disc's overlap with the back opening (the disc lies inside the front one).
  auto centroid = [&](const cv::Point2d& back)
  { return discOverlap(view.region_centre, view.region_radius, back, back_radius); };
  const double x_f = (in.front.x - camera.cx) / camera.fx * depth;
  const double y_f = (in.front.y - camera.cy) / camera.fy * depth;
  cv::Point2d back = start.value_or(cv::Point2d(camera.cx + camera.fx * x_f / (depth + in.length),
                                                camera.cy + camera.fy * y_f / (depth + in.length)));
  constexpr double kStep = 0.02;  // px, for the numerical Jacobian
  constexpr int kIterations = 30;
  bool converged = false;
  for (int i = 0; i < kIterations && !converged; ++i)
  {
    const DiscOverlap o = centroid(back);
    const DiscOverlap ox = centroid(back + cv::Point2d(kStep, 0.0));
    const DiscOverlap oy = centroid(back + cv::Point2d(0.0, kStep));
    if (!(o.area > 0.0 && ox.area > 0.0 && oy.area > 0.0))
      return std::nullopt;
    const cv::Matx22d j((ox.centroid.x - o.centroid.x) / kStep, (oy.centroid.x - o.centroid.x) / kStep,
                        (ox.centroid.y - o.centroid.y) / kStep, (oy.centroid.y - o.centroid.y) / kStep);
    const cv::Vec2d residual(o.centroid.x - in.lens.x, o.centroid.y - in.lens.y);
    cv::Vec2d step;
    if (!cv::solve(j, -residual, step))
      return std::nullopt;
    // A step at most half the back opening's radius keeps the two discs overlapping.
    const double norm = std::hypot(step[0], step[1]);
    if (norm > 0.5 * back_radius)
      step *= 0.5 * back_radius / norm;
    back += cv::Point2d(step[0], step[1]);
    converged = norm < 1e-4;
  }
  if (!converged)
    return std::nullopt;
  // The back centre P_f + L a with a = (sx, sy, 1) / n: (u_b - cx) / fx (z_f + L / n) = x_f + L sx / n.
  cv::Vec2d slopes(0.0, 0.0);
  for (int i = 0; i < 3; ++i)
  {
    const double n = std::sqrt(1.0 + slopes.dot(slopes));
    slopes = {((back.x - camera.cx) / camera.fx * (depth * n + in.length) - x_f * n) / in.length,
              ((back.y - camera.cy) / camera.fy * (depth * n + in.length) - y_f * n) / in.length};
  }
  return Solution{slopes, back, centroid(back).area};
}
}  // namespace

std::optional<LensView> measureLens(const LinearLight& light, const CameraIntrinsics& camera, const cv::Point2d& centre,
                                    double radius, std::vector<float>& samples)
{
  const double inner = radius - lensMargin(radius);
  const cv::Mat& gray8 = *light.gray;
  if (!(inner >= 4.0) || gray8.type() != CV_8UC1)
    return std::nullopt;
  const int x0 = cvFloor(centre.x - inner);
  const int x1 = cvCeil(centre.x + inner);
  const int y0 = cvFloor(centre.y - inner);
  const int y1 = cvCeil(centre.y + inner);
  // Both passes visit the disc's pixels in the same order.
  auto forEachPixel = [&](auto&& visit)
  {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        if ((x - centre.x) * (x - centre.x) + (y - centre.y) * (y - centre.y) <= inner * inner)
          visit(x, y);
  };
  samples.clear();
  bool inside = true;
  std::array<int, 256> histogram{};
  forEachPixel(
      [&](int x, int y)
      {
        const cv::Point2d seen = distortPixel(camera, {double(x), double(y)});
        inside = inside && seen.x >= 0.0 && seen.y >= 0.0 && seen.x < gray8.cols - 1 && seen.y < gray8.rows - 1;
        // In linear light: the camera's gamma would put a blurred edge's half-way level on its dark side.
        const float value = 255.0f * linearLightAt(light, static_cast<float>(seen.x), static_cast<float>(seen.y));
        samples.push_back(value);
        ++histogram[static_cast<std::size_t>(std::clamp(value, 0.0f, 255.0f))];
      });
  if (!inside || samples.empty())
    return std::nullopt;  // the disc leaves the frame
  auto percentile = [&](double q)
  {
    const double wanted = q * double(samples.size());
    int seen = 0;
    for (std::size_t level = 0; level < histogram.size(); ++level)
      if ((seen += histogram[level]) >= wanted)
        return double(level);
    return 255.0;
  };
  const double dark = percentile(0.05);
  const double lit = percentile(0.98);
  if (!(lit - dark >= kMinLensContrast * 255.0))
    return std::nullopt;
  double sum = 0.0;
  cv::Point2d moment(0.0, 0.0);
  std::size_t i = 0;
  forEachPixel(
      [&](int x, int y)
      {
        const double w = std::clamp(2.0 * (samples[i++] - dark) / (lit - dark) - 0.5, 0.0, 1.0);
        sum += w;
        moment += w * cv::Point2d(x, y);
      });
  const double fraction = sum / double(samples.size());
  if (fraction < 0.03 || fraction > 0.97)
    return std::nullopt;
  LensView view;
  view.centroid = moment / sum;
  view.area = sum;
  view.region_centre = centre;
  view.region_radius = inner;
  return view;
}

DiscOverlap discOverlap(const cv::Point2d& c1, double r1, const cv::Point2d& c2, double r2)
{
  DiscOverlap out;
  out.centroid = {SpoolDetection::kNaN, SpoolDetection::kNaN};
  const cv::Point2d delta = c2 - c1;
  const double d = std::hypot(delta.x, delta.y);
  if (!(d < r1 + r2))
    return out;
  if (d <= std::abs(r1 - r2))
  {
    // One disc inside the other: the smaller whole.
    const bool first = r1 <= r2;
    out.area = CV_PI * std::min(r1, r2) * std::min(r1, r2);
    out.centroid = first ? c1 : c2;
    return out;
  }
  // The common chord at distance a from c1 (towards c2), d - a from c2.
  const double a = (d * d + r1 * r1 - r2 * r2) / (2.0 * d);
  const double half_chord = std::sqrt(std::max(0.0, r1 * r1 - a * a));
  double area1 = 0.0;
  double offset1 = 0.0;
  double area2 = 0.0;
  double offset2 = 0.0;
  segment(r1, a, half_chord, area1, offset1);
  segment(r2, d - a, half_chord, area2, offset2);
  out.area = area1 + area2;
  const double along = (area1 * offset1 + area2 * (d - offset2)) / out.area;  // from c1 towards c2
  out.centroid = c1 + delta * (along / d);
  return out;
}

std::optional<ParallaxAxis> axisFromBoreParallax(const GeometryParams& geometry, const CameraIntrinsics& camera,
                                                 const cv::Point2d& front_centre, double depth, const LensView& lens)
{
  if (!(depth > 0.0) || !(geometry.hub_length > 0.0) || !(lens.area > 0.0))
    return std::nullopt;
  const Inputs nominal{lens.centroid, front_centre, geometry.hub_length};
  const std::optional<Solution> solution = solve(nominal, geometry, camera, depth, lens, std::nullopt);
  if (!solution || std::abs(lens.area - solution->area) > solution->area / 3.0)
    return std::nullopt;
  // First-order propagation: one column of the Jacobian per input, by central differences.
  const double sigmas[5] = {kLensCentroidSigmaPx, kLensCentroidSigmaPx, kFrontCentreSigmaPx, kFrontCentreSigmaPx,
                            kBoreLengthSpread * geometry.hub_length};
  cv::Matx22d covariance = cv::Matx22d::zeros();
  for (int k = 0; k < 5; ++k)
  {
    const double h = 0.5 * sigmas[k];
    Inputs plus = nominal;
    Inputs minus = nominal;
    double* p[] = {&plus.lens.x, &plus.lens.y, &plus.front.x, &plus.front.y, &plus.length};
    double* m[] = {&minus.lens.x, &minus.lens.y, &minus.front.x, &minus.front.y, &minus.length};
    *p[k] += h;
    *m[k] -= h;
    // From the nominal solution: a few Newton steps each.
    const std::optional<Solution> up = solve(plus, geometry, camera, depth, lens, solution->back);
    const std::optional<Solution> down = solve(minus, geometry, camera, depth, lens, solution->back);
    if (!up || !down)
      return std::nullopt;
    const cv::Vec2d column = (up->slopes - down->slopes) * (sigmas[k] / (2.0 * h));
    covariance += column * column.t();
  }
  return ParallaxAxis{solution->slopes, covariance};
}

}  // namespace spool_vision
