#include "spool_vision/moving_edges.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "cpu_dispatch.h"
#include "spool_vision/camera_model.h"
#include "spool_vision/hough_accumulator.h"

namespace spool_vision
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kSampleSpacing = 5.0;  // px of rim between samples
// The least share of a rim in the frame that more samples are spread for (at most 4x as many).
constexpr double kMinInViewShare = 0.25;
// A step that a 3x3 Sobel answers with its full scale (4 * 255) rises by 255 over the two pixels
// a central difference spans: edge_threshold t is a half-difference of t * 127.5 levels per px.
constexpr double kHalfDifferenceFullScale = 127.5;
// A normal distribution's sigma is 1.4826 median absolute deviations.
constexpr double kMadToSigma = 1.4826;
// px: the span in which the edges' offsets are taken as one crowd (the rim's own agree within a
// px; another edge beside it lies 2-5 px off at 160x120).
constexpr double kModeWindow = 2.0;
// px, the least band about the first shift and about the fit (3 MAD sigmas where wider)
constexpr double kMinFirstBand = 2.0;
constexpr double kMinBand = 1.0;

// A row of gray levels, as cv::cvtColor weighs the channels (ITU-R BT.601), in float: a rim's
// profile is read between pixels.
template <int kChannels, int kBlue, int kRed>
inline void colourRow(const uchar* p, int cols, float* out)
{
  for (int x = 0; x < cols; ++x, p += kChannels)
    out[x] = 0.114f * p[kBlue] + 0.587f * p[1] + 0.299f * p[kRed];
}

// `cols` pixels of `format` from `p` as gray levels (a per-pixel loop: AVX2 where the CPU has it).
SPOOL_VISION_PIXEL_LOOP void grayRow(const uchar* p, int cols, PixelFormat format, float* out)
{
  switch (format)
  {
    case PixelFormat::kMono8:
      for (int x = 0; x < cols; ++x)
        out[x] = p[x];
      break;
    case PixelFormat::kMono16:
    {
      const auto* p16 = reinterpret_cast<const ushort*>(p);
      for (int x = 0; x < cols; ++x)
        out[x] = p16[x] * (1.0f / 257.0f);  // 65535 -> 255, as Preprocessor::toGray
      break;
    }
    case PixelFormat::kBgr8:
      colourRow<3, 0, 2>(p, cols, out);
      break;
    case PixelFormat::kRgb8:
      colourRow<3, 2, 0>(p, cols, out);
      break;
    case PixelFormat::kBgra8:
      colourRow<4, 0, 2>(p, cols, out);
      break;
    case PixelFormat::kRgba8:
      colourRow<4, 2, 0>(p, cols, out);
      break;
  }
}

// Bilinear interpolation of `levels` (CV_32F) at (x, y), inside [0, cols - 1) x [0, rows - 1).
float bilinear(const cv::Mat& levels, double x, double y)
{
  const int x0 = static_cast<int>(x);
  const int y0 = static_cast<int>(y);
  const float fx = static_cast<float>(x - x0);
  const float fy = static_cast<float>(y - y0);
  const float* upper = levels.ptr<float>(y0) + x0;
  const float* lower = levels.ptr<float>(y0 + 1) + x0;
  const float top = upper[0] + fx * (upper[1] - upper[0]);
  const float bottom = lower[0] + fx * (lower[1] - lower[0]);
  return top + fy * (bottom - top);
}

double median(std::vector<double>& v)
{
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The value most of `v` agree on: the median of the most values any `window` wide span holds
// (`v` sorted in place).
double densest(std::vector<double>& v, double window)
{
  std::sort(v.begin(), v.end());
  std::size_t best_first = 0;
  std::size_t best_count = 0;
  for (std::size_t first = 0, end = 0; first < v.size(); ++first)
  {
    while (end < v.size() && v[end] - v[first] <= window)
      ++end;
    if (end - first > best_count)
    {
      best_count = end - first;
      best_first = first;
    }
  }
  return v[best_first + best_count / 2];
}
}  // namespace

void MovingEdges::setCamera(const CameraIntrinsics& camera)
{
  if (!camera.valid())
    throw std::invalid_argument("MovingEdges: invalid camera intrinsics");
  camera_ = camera;
}

bool MovingEdges::project(const RimPrediction& prediction, int count)
{
  cv::Vec3d a = prediction.axis;
  if (!(std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2])) || cv::norm(a) < 1e-9)
    a = cv::Vec3d(0.0, 0.0, 1.0);
  a = cv::normalize(a);
  // Two unit vectors spanning the rim's plane.
  const cv::Vec3d up = std::abs(a[1]) < 0.9 ? cv::Vec3d(0.0, 1.0, 0.0) : cv::Vec3d(1.0, 0.0, 0.0);
  const cv::Vec3d u = cv::normalize(a.cross(up));
  const cv::Vec3d v = a.cross(u);
  const cv::Vec3d c(prediction.centre.x, prediction.centre.y, prediction.centre.z);
  const double xc = camera_.fx * c[0] / c[2] + camera_.cx;
  const double yc = camera_.fy * c[1] / c[2] + camera_.cy;
  points_.resize(static_cast<std::size_t>(count));
  normals_.resize(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k)
  {
    const double theta = 2.0 * kPi * k / count;
    const cv::Vec3d along = std::cos(theta) * u + std::sin(theta) * v;
    const cv::Vec3d p = c + prediction.radius * along;
    if (!(p[2] > 0.01))
      return false;
    const double x = camera_.fx * p[0] / p[2] + camera_.cx;
    const double y = camera_.fy * p[1] / p[2] + camera_.cy;
    // The image tangent: the pinhole's Jacobian times the rim's 3-D tangent.
    const cv::Vec3d t = prediction.radius * (-std::sin(theta) * u + std::cos(theta) * v);
    const double du = camera_.fx * (t[0] / p[2] - p[0] * t[2] / (p[2] * p[2]));
    const double dv = camera_.fy * (t[1] / p[2] - p[1] * t[2] / (p[2] * p[2]));
    const double norm = std::hypot(du, dv);
    if (!(norm > 0.0))
      return false;
    cv::Point2d n(dv / norm, -du / norm);
    if (n.x * (x - xc) + n.y * (y - yc) < 0.0)
      n = -n;
    points_[static_cast<std::size_t>(k)] = {x, y};
    normals_[static_cast<std::size_t>(k)] = n;
  }
  return true;
}

void MovingEdges::beginFrame()
{
  holds_frame_ = true;
  levels_of_ = nullptr;
}

void MovingEdges::endFrame()
{
  holds_frame_ = false;
}

void MovingEdges::keepLevelsOf(const cv::Mat& image, PixelFormat format)
{
  if (holds_frame_ && image.data == levels_of_ && format == levels_format_ && image.step[0] == levels_step_ &&
      levels_.size() == image.size())
    return;
  levels_.create(image.size(), CV_32F);
  level_tiles_.assign(static_cast<std::size_t>((image.cols + kLevelTile - 1) / kLevelTile) *
                          ((image.rows + kLevelTile - 1) / kLevelTile),
                      0);
  levels_of_ = image.data;
  levels_format_ = format;
  levels_step_ = image.step[0];
}

void MovingEdges::convertTiles(const cv::Mat& image, PixelFormat format, const cv::Rect& region)
{
  const int tiles_x = (image.cols + kLevelTile - 1) / kLevelTile;
  const cv::Rect inside = region & cv::Rect(0, 0, image.cols, image.rows);
  if (inside.empty())
    return;
  for (int ty = inside.y / kLevelTile; ty <= (inside.br().y - 1) / kLevelTile; ++ty)
    for (int tx = inside.x / kLevelTile; tx <= (inside.br().x - 1) / kLevelTile; ++tx)
    {
      unsigned char& done = level_tiles_[static_cast<std::size_t>(ty * tiles_x + tx)];
      if (done)
        continue;
      done = 1;
      const int x0 = tx * kLevelTile;
      const int cols = std::min(kLevelTile, image.cols - x0);
      for (int y = ty * kLevelTile; y < std::min((ty + 1) * kLevelTile, image.rows); ++y)
        grayRow(image.ptr<uchar>(y) + x0 * image.elemSize(), cols, format, levels_.ptr<float>(y) + x0);
    }
}

std::size_t MovingEdges::searchNormals(const cv::Mat& image, PixelFormat format, const RimSearch& search)
{
  const cv::Size size = image.size();
  const int reach = std::max(1, static_cast<int>(std::ceil(search.reach)));
  const int half = search.sigma >= 0.3 ? static_cast<int>(std::ceil(3.0 * search.sigma)) : 0;
  kernel_.resize(static_cast<std::size_t>(2 * half + 1));
  float total = 0.0f;
  for (int k = -half; k <= half; ++k)
  {
    const float w = half > 0 ? std::exp(static_cast<float>(-0.5 * k * k / (search.sigma * search.sigma))) : 1.0f;
    kernel_[static_cast<std::size_t>(k + half)] = w;
    total += w;
  }
  for (float& w : kernel_)
    w /= total;
  // The profile spans the reach, one more px each way for the central difference, and the kernel.
  const int outer = reach + 1 + half;
  profile_.resize(static_cast<std::size_t>(2 * outer + 1));
  smoothed_.resize(static_cast<std::size_t>(2 * reach + 3));
  const float sign = search.polarity == Polarity::kBright ? -1.0f : 1.0f;
  const float least = static_cast<float>(search.threshold * kHalfDifferenceFullScale);
  const double max_x = size.width - 1.001;
  const double max_y = size.height - 1.001;
  auto inside = [&](const cv::Point2d& q) { return q.x >= 0.0 && q.y >= 0.0 && q.x <= max_x && q.y <= max_y; };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  found_.assign(points_.size(), {nan, nan});
  std::size_t in_frame = 0;
  for (std::size_t i = 0; i < points_.size(); ++i)
  {
    // The normal in the raw frame: the lens bends it little over a few px, so its two ends decide.
    const cv::Point2d q0 = distortPixel(camera_, points_[i]);
    const cv::Point2d step = distortPixel(camera_, points_[i] + normals_[i]) - q0;
    const double length = std::hypot(step.x, step.y);
    if (!(length > 0.0))
      continue;
    const cv::Point2d across(-step.y / length, step.x / length);
    const cv::Point2d first = q0 - outer * step;
    const cv::Point2d last = q0 + outer * step;
    if (!inside(first - across) || !inside(first + across) || !inside(last - across) || !inside(last + across))
      continue;
    ++in_frame;
    // The pixels the profile's two lines read (bilinear: the next row and column too).
    const double xs[] = {first.x - across.x, first.x + across.x, last.x - across.x, last.x + across.x};
    const double ys[] = {first.y - across.y, first.y + across.y, last.y - across.y, last.y + across.y};
    const int left = static_cast<int>(*std::min_element(std::begin(xs), std::end(xs)));
    const int top = static_cast<int>(*std::min_element(std::begin(ys), std::end(ys)));
    convertTiles(image, format,
                 cv::Rect(cv::Point(left, top),
                          cv::Point(static_cast<int>(*std::max_element(std::begin(xs), std::end(xs))) + 2,
                                    static_cast<int>(*std::max_element(std::begin(ys), std::end(ys))) + 2)));
    // Two parallel lines a px apart, averaged: the filter's smoothing along the rim.
    const cv::Point2d side = 0.5 * across;
    for (int s = -outer; s <= outer; ++s)
    {
      const cv::Point2d q = q0 + s * step;
      profile_[static_cast<std::size_t>(s + outer)] =
          0.5f * (bilinear(levels_, q.x - side.x, q.y - side.y) + bilinear(levels_, q.x + side.x, q.y + side.y));
    }
    // Tap by tap over the whole profile (each point's sum still taken in tap order): the loop
    // over the points vectorises.
    const std::size_t points = smoothed_.size();
    std::fill(smoothed_.begin(), smoothed_.end(), 0.0f);
    for (int k = 0; k <= 2 * half; ++k)
    {
      const float w = kernel_[static_cast<std::size_t>(k)];
      const float* in = profile_.data() + (outer - reach - 1 - half + k);
      float* out = smoothed_.data();
      for (std::size_t j = 0; j < points; ++j)
        out[j] += w * in[j];
    }
    // The outward gradient at s (half the central difference), the way the polarity wants it.
    auto gradient = [&](int s)
    {
      const float g =
          0.5f * (smoothed_[static_cast<std::size_t>(s + reach + 2)] - smoothed_[static_cast<std::size_t>(s + reach)]);
      return search.polarity == Polarity::kAny ? std::abs(g) : sign * g;
    };
    int best = 0;
    float best_g = least;
    bool any = false;
    for (int s = -reach; s <= reach; ++s)
    {
      const float g = gradient(s);
      if (g >= best_g)
      {
        best_g = g;
        best = s;
        any = true;
      }
    }
    if (!any)
      continue;
    double offset = best;
    if (best > -reach && best < reach)
    {
      // The parabola through the peak and its neighbours puts it between samples.
      const double gm = gradient(best - 1);
      const double gp = gradient(best + 1);
      const double curvature = gm - 2.0 * best_g + gp;
      if (curvature < 0.0)
        offset += std::clamp(0.5 * (gm - gp) / curvature, -0.5, 0.5);
    }
    found_[i] = points_[i] + offset * normals_[i];
  }
  return in_frame;
}

bool MovingEdges::fit(cv::Size size, std::size_t in_frame, double max_band_share, Circle& rim)
{
  // The predicted rim as the detector's rim model (fitRimModel() on its own samples).
  Circle predicted;
  double cx = 0.0;
  double cy = 0.0;
  for (const cv::Point2d& p : points_)
  {
    cx += p.x;
    cy += p.y;
  }
  predicted.x = cx / static_cast<double>(points_.size());
  predicted.y = cy / static_cast<double>(points_.size());
  double mean_distance = 0.0;
  for (const cv::Point2d& p : points_)
    mean_distance += std::hypot(p.x - predicted.x, p.y - predicted.y);
  predicted.r = predicted.r_horizontal = predicted.r_vertical = mean_distance / static_cast<double>(points_.size());
  RimMoments own;
  for (const cv::Point2d& p : points_)
    own.add((p.x - predicted.x) / predicted.r, (p.y - predicted.y) / predicted.r);
  if (!fitRimModel(own, predicted.r, predicted))
    return false;

  // The rim found is the predicted one moved by (dx, dy) and scaled by 1 + e about its centre: its
  // shape is the tracked axis's. Each edge measures that along its normal only (where along the
  // rim it lies is arbitrary): offset_i = n_i . (dx, dy) + e n_i . (p_i - centre), least squares.
  // A rim cut by the frame shows an arc, on which a free ellipse trades its height for its width
  // and its centre; the tracked shape does not, and SpoolGeometry fits the pose to the edges.
  // Each edge's offset along its normal, and the row of the motion's least squares.
  auto offset = [&](std::size_t i) { return (found_[i] - points_[i]).dot(normals_[i]); };
  auto row = [&](std::size_t i)
  {
    return Eigen::Vector3d(normals_[i].x, normals_[i].y,
                           normals_[i].dot(points_[i] - cv::Point2d(predicted.x, predicted.y)));
  };
  // First about the median offset (a rim shifted along its normals), then about the fit. With
  // max_band_share, about the offset most edges agree on, in a band at most that wide: where a
  // second edge runs beside the rim (a dark gap between spools, blur), the offsets fall in two
  // crowds, and their median and a band wide enough for both fit a rim between them
  // (approach_hard seed 73002 at 160x120: a tracked flange 3% large, then 8% as the track followed it).
  scratch_.clear();
  for (std::size_t i = 0; i < found_.size(); ++i)
    if (std::isfinite(found_[i].x))
      scratch_.push_back(offset(i));
  if (scratch_.size() < kMinEdges)
    return false;
  const bool narrow = max_band_share > 0.0;
  const double shift = narrow ? densest(scratch_, kModeWindow) : median(scratch_);
  for (double& d : scratch_)
    d = std::abs(d - shift);
  const double widest =
      narrow ? std::max(kMinFirstBand, max_band_share * predicted.r) : std::numeric_limits<double>::infinity();
  double band = std::clamp(3.0 * kMadToSigma * median(scratch_), kMinFirstBand, widest);
  Eigen::Vector3d motion = Eigen::Vector3d::Zero();
  auto off = [&](std::size_t i, int pass) { return offset(i) - (pass == 0 ? shift : row(i).dot(motion)); };
  constexpr int kFits = 3;
  for (int pass = 0; pass < kFits; ++pass)
  {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    std::size_t taken = 0;
    for (std::size_t i = 0; i < found_.size(); ++i)
    {
      if (!std::isfinite(found_[i].x) || std::abs(off(i, pass)) > band)
        continue;
      const Eigen::Vector3d r = row(i);
      normal += r * r.transpose();
      rhs += r * offset(i);
      ++taken;
    }
    if (taken < kMinEdges)
      return false;
    const Eigen::LDLT<Eigen::Matrix3d> solver(normal);
    if (solver.info() != Eigen::Success)
      return false;
    motion = solver.solve(rhs);
    if (!motion.allFinite() || !(1.0 + motion(2) > 0.0))
      return false;
    scratch_.clear();
    for (std::size_t i = 0; i < found_.size(); ++i)
      if (std::isfinite(found_[i].x))
        scratch_.push_back(std::abs(off(i, kFits)));
    band = std::clamp(3.0 * kMadToSigma * median(scratch_), kMinBand, widest);
  }
  on_rim_.clear();
  for (std::size_t i = 0; i < found_.size(); ++i)
    if (std::isfinite(found_[i].x) && std::abs(off(i, kFits)) <= band)
      on_rim_.emplace_back(static_cast<float>(found_[i].x), static_cast<float>(found_[i].y));
  if (on_rim_.size() < kMinEdges)
    return false;
  const double scale = 1.0 + motion(2);
  Circle model = predicted;
  model.x += motion(0);
  model.y += motion(1);
  model.r *= scale;
  model.r_horizontal *= scale;
  model.r_vertical *= scale;
  model.visible_fraction = visibleRimFraction(model.x, model.y, model.r, size);
  scale_ = scale;
  model.score =
      std::min(1.0, static_cast<double>(on_rim_.size()) / static_cast<double>(std::max<std::size_t>(in_frame, 1)));
  rim = model;
  return true;
}

bool MovingEdges::measure(const cv::Mat& image, PixelFormat format, const RimPrediction& prediction,
                          const RimSearch& search, Circle& rim)
{
  if (image.empty() || image.type() != matTypeOf(format))
    throw std::invalid_argument("MovingEdges: the image's type does not fit its pixel format");
  on_rim_.clear();
  found_.clear();
  in_frame_ = 0;
  sparse_in_view_ = false;
  keepLevelsOf(image, format);
  if (!(prediction.centre.z > 0.01) || !(prediction.radius > 0.0))
    return false;
  const double circumference = 2.0 * kPi * camera_.fy * prediction.radius / prediction.centre.z;
  // A rim cut by the frame keeps as many samples inside it as a whole one would have: the rim
  // fits after this ask for a number of points, not a fraction of the rim.
  const double in_view = search.samples_in_view
                             ? visibleRimFraction(camera_.fx * prediction.centre.x / prediction.centre.z + camera_.cx,
                                                  camera_.fy * prediction.centre.y / prediction.centre.z + camera_.cy,
                                                  circumference / (2.0 * kPi), image.size())
                             : 1.0;
  const double cap = std::clamp(search.max_samples, kMinSamples, kMaxSamples) / std::max(in_view, kMinInViewShare);
  const int spaced = static_cast<int>(circumference / kSampleSpacing);
  const int count = std::clamp(spaced, kMinSamples, std::max(kMinSamples, static_cast<int>(cap)));
  if (!project(prediction, count))
    return false;
  const std::size_t in_frame = searchNormals(image, format, search);
  in_frame_ = in_frame;
  sparse_in_view_ = count < spaced && in_frame < static_cast<std::size_t>(count);
  return fit(image.size(), in_frame, search.max_band_share, rim);
}

}  // namespace spool_vision
