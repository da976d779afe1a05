#include "spool_vision/hough_accumulator.h"

#include <algorithm>
#include <array>
#include <bitset>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "cpu_dispatch.h"
#include "spool_vision/camera_model.h"

namespace spool_vision
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
// A 3x3 Sobel answers 4 * 255 to a full-scale step.
constexpr float kSobelFullScale = 4.0f * 255.0f;
// Edge direction must agree with the radial direction within ~30 degrees to support a rim.
constexpr float kMinRadialAlignment = 0.866f;
constexpr int kRimSamples = 64;

// Sign that turns a dark-to-bright gradient into the direction from the rim to the centre; 0 when
// either direction may be (Polarity::kAny).
float centreSign(Polarity polarity)
{
  switch (polarity)
  {
    case Polarity::kBright:
      return 1.0f;
    case Polarity::kDark:
      return -1.0f;
    case Polarity::kAny:
      break;
  }
  return 0.0f;
}

// True when an edge at offset (vx, vy), |offset|^2 = d2, from a centre has its gradient along the
// radius, pointing the way `sign` (centreSign()) wants: away from the centre for a dark disc.
// Squares are compared, so the callers' inner loops take no square root for edges it rejects.
// `&`, not `&&`: the scans over every edge test this unpredictably, and a mispredicted branch
// costs more than the second comparison.
template <typename T>
bool radial(T vx, T vy, T d2, const EdgePoint& e, float sign)
{
  const T along = vx * e.dx + vy * e.dy;
  const T toward = sign == 0.0f ? std::abs(along) : -sign * along;
  return (toward >= 0) & (toward * toward >= kMinRadialAlignment * kMinRadialAlignment * d2);
}

// Adds each edge's votes along its gradient (the side `sign`, centreSign()) for the centres at
// r0 + i cell, i < steps, with weight[i], to `data`: size.width x size.height cells from `origin`
// (px), then `steps` spare cells that take the votes falling off the accumulator. The cells of one
// edge are found first (a loop the compiler vectorises: positions in 16.16 fixed point, exact
// and the same on every CPU) and added after; `cells` holds `steps`. No branch per vote.
SPOOL_VISION_PIXEL_LOOP void castVotes(const EdgePoint* edges, std::size_t count, float sign, float r0, float inv_cell,
                                       cv::Point2f origin, const float* weight, int steps, cv::Size size, int* cells,
                                       float* data)
{
  constexpr float kOne = 65536.0f;
  // Positions off by more than this many cells take no vote anyway; the clamp keeps the fixed
  // point away from overflow.
  constexpr float kFar = 16384.0f;
  const int spare = size.width * size.height;
  for (std::size_t k = 0; k < count; ++k)
  {
    const EdgePoint& e = edges[k];
    // Accumulator coordinates of the centre at r0 (rounded to the nearest cell by the half added)
    // and the step per radius increment.
    const float ax = std::clamp((e.x + sign * r0 * e.dx - origin.x) * inv_cell + 0.5f, -kFar, kFar);
    const float ay = std::clamp((e.y + sign * r0 * e.dy - origin.y) * inv_cell + 0.5f, -kFar, kFar);
    const auto x0 = static_cast<std::int32_t>(std::lround(ax * kOne));
    const auto y0 = static_cast<std::int32_t>(std::lround(ay * kOne));
    const auto sx = static_cast<std::int32_t>(std::lround(sign * e.dx * kOne));
    const auto sy = static_cast<std::int32_t>(std::lround(sign * e.dy * kOne));
    for (int i = 0; i < steps; ++i)
    {
      const std::int32_t ix = (x0 + i * sx) >> 16;  // floor
      const std::int32_t iy = (y0 + i * sy) >> 16;
      const bool inside = (ix >= 0) & (iy >= 0) & (ix < size.width) & (iy < size.height);
      cells[i] = inside ? iy * size.width + ix : spare + i;
    }
    for (int i = 0; i < steps; ++i)
      data[cells[i]] += weight[i];
  }
}

// The rim fit's bands (fraction of the radius) per pass: the first passes take a wide band so an
// elliptic rim (up to ~12% stretch) is caught whole; then it narrows onto the fitted model. Four
// fitting passes, then one that only counts the support of the final model: a fit to a short arc
// can move far, and the score must describe the circle returned, not the last input.
constexpr double kFitBands[] = {0.12, 0.06, 0.025, 0.025, 0.025};
constexpr int kFits = 4;
// The first pass of the narrow band.
constexpr int kNarrowPass = 2;

// The spare bins radiusBins() spreads the non-supporting edges over: successive additions to one
// bin wait for each other.
constexpr int kSpareBins = 8;

// For each edge, the bin (radius - lo, rounded) of its distance from `centre` where it supports
// a rim of radius lo..hi there (radial() for `sign`); else one of kSpareBins bins from `bins` on.
// A loop the compiler vectorises, with no branch per edge: measureRadius() runs it over every edge
// of the frame for every peak.
SPOOL_VISION_PIXEL_LOOP void radiusBins(const EdgePoint* edges, std::size_t count, cv::Point2f centre, float lo,
                                        float hi, float sign, int bins, std::uint32_t* out)
{
  const float lo2 = lo * lo;
  const float hi2 = hi * hi;
  for (std::size_t i = 0; i < count; ++i)
  {
    const EdgePoint& e = edges[i];
    const float vx = e.x - centre.x;
    const float vy = e.y - centre.y;
    const float d2 = vx * vx + vy * vy;
    const bool aligned = radial(vx, vy, d2, e, sign);
    const bool supports = (d2 >= lo2) & (d2 <= hi2) & aligned;
    const int bin = static_cast<int>(std::sqrt(d2) - lo + 0.5f);
    out[i] = static_cast<std::uint32_t>(supports ? bin : bins + static_cast<int>(i % kSpareBins));
  }
}

// keep[i] = 1 where edges[i] lies `inner2`..`outer2` (squared px) from `centre` on its `side` (a
// direction; zero = all round), else 0. Vectorised, no branch per edge.
SPOOL_VISION_PIXEL_LOOP void inAnnulus(const EdgePoint* edges, std::size_t count, cv::Point2d centre, double inner2,
                                       double outer2, cv::Point2d side, std::uint8_t* keep)
{
  for (std::size_t i = 0; i < count; ++i)
  {
    const double vx = edges[i].x - centre.x;
    const double vy = edges[i].y - centre.y;
    const double d2 = vx * vx + vy * vy;
    keep[i] = static_cast<std::uint8_t>((d2 >= inner2) & (d2 <= outer2) & (vx * side.x + vy * side.y >= 0.0));
  }
}

// keep[i] = 1 where edges[i] supports the axis-aligned ellipse about `centre` with 1/semi-axis^2
// `inv_x2`, `inv_y2`: inside its band rho^2 in [rho_min2, rho_max2] and radial() for `sign`.
SPOOL_VISION_PIXEL_LOOP void inEllipseBand(const EdgePoint* edges, std::size_t count, cv::Point2d centre, double inv_x2,
                                           double inv_y2, double rho_min2, double rho_max2, float sign,
                                           std::uint8_t* keep)
{
  // In float, as the edges are: eight lanes, not four.
  const auto cx = static_cast<float>(centre.x);
  const auto cy = static_cast<float>(centre.y);
  const auto ix2 = static_cast<float>(inv_x2);
  const auto iy2 = static_cast<float>(inv_y2);
  const auto lo2 = static_cast<float>(rho_min2);
  const auto hi2 = static_cast<float>(rho_max2);
  for (std::size_t i = 0; i < count; ++i)
  {
    const EdgePoint& e = edges[i];
    const float vx = e.x - cx;
    const float vy = e.y - cy;
    const float rho2 = vx * vx * ix2 + vy * vy * iy2;
    const bool aligned = radial(vx, vy, vx * vx + vy * vy, e, sign);
    keep[i] = static_cast<std::uint8_t>((rho2 >= lo2) & (rho2 <= hi2) & aligned);
  }
}

// weight[i] = 1 - off / band where edges[i] lies off = |rho - 1| mean_r px off the ellipse about
// `c` (rho^2 = xx vx^2 + xy vx vy + yy vy^2, HoughAccumulator::EllipseForm) within `band` and is
// radial() for `sign`; else -1. Vectorised, no branch per edge; in double, each lane doing what a
// plain loop does, so that the sums over it (in edge order) are the same.
SPOOL_VISION_PIXEL_LOOP void ellipseWeights(const EdgePoint* edges, std::size_t count, cv::Point2d c, double xx,
                                            double xy, double yy, double mean_r, double band, float sign,
                                            double* weight)
{
  for (std::size_t i = 0; i < count; ++i)
  {
    const EdgePoint& e = edges[i];
    const double vx = e.x - c.x;
    const double vy = e.y - c.y;
    const double off = std::abs(std::sqrt(vx * vx * xx + vx * vy * xy + vy * vy * yy) - 1.0) * mean_r;
    const bool aligned = radial(vx, vy, vx * vx + vy * vy, e, sign);
    weight[i] = ((off <= band) & aligned) ? 1.0 - off / band : -1.0;
  }
}

// 3x3 Sobel and squared magnitude with replicated borders, into gx, gy (CV_16S) and mag (CV_32S)
// of gray8's size. Each row in plain passes the compiler vectorises: the column sums and
// differences first (into `sum` and `diff`, gray8.cols + 2 each: padded by the replicated border),
// then the row taps.
SPOOL_VISION_PIXEL_LOOP void sobel(const cv::Mat& gray8, short* column_sum, short* column_diff, cv::Mat& gx_out,
                                   cv::Mat& gy_out, cv::Mat& mag_out)
{
  const int w = gray8.cols;
  const int h = gray8.rows;
  for (int y = 0; y < h; ++y)
  {
    const uchar* __restrict up = gray8.ptr<uchar>(std::max(y - 1, 0));
    const uchar* __restrict mid = gray8.ptr<uchar>(y);
    const uchar* __restrict down = gray8.ptr<uchar>(std::min(y + 1, h - 1));
    short* __restrict sum = column_sum + 1;
    short* __restrict diff = column_diff + 1;
    for (int x = 0; x < w; ++x)
    {
      sum[x] = static_cast<short>(up[x] + 2 * mid[x] + down[x]);
      diff[x] = static_cast<short>(down[x] - up[x]);
    }
    sum[-1] = sum[0];
    sum[w] = sum[w - 1];
    diff[-1] = diff[0];
    diff[w] = diff[w - 1];
    short* __restrict gx = gx_out.ptr<short>(y);
    short* __restrict gy = gy_out.ptr<short>(y);
    int* __restrict m = mag_out.ptr<int>(y);
    for (int x = 0; x < w; ++x)
    {
      const short dx = static_cast<short>(sum[x + 1] - sum[x - 1]);
      const short dy = static_cast<short>(diff[x - 1] + 2 * diff[x] + diff[x + 1]);
      gx[x] = dx;
      gy[x] = dy;
      m[x] = dx * dx + dy * dy;
    }
  }
}

// The 3x3 binomial of rows a, b, c at columns 1..cols-2 into out (a per-pixel loop: AVX2 where the
// CPU has it; each cell's sum in the same order either way).
SPOOL_VISION_PIXEL_LOOP void binomial3x3Row(const float* a, const float* b, const float* c, int cols, float* out)
{
  for (int x = 1; x + 1 < cols; ++x)
    out[x] = (a[x - 1] + 2 * a[x] + a[x + 1] + 2 * (b[x - 1] + 2 * b[x] + b[x + 1]) + c[x - 1] + 2 * c[x] + c[x + 1]) *
             (1.0f / 16.0f);
}

// How many of m[0..count) are at least t2, and the largest of them and `strongest`.
SPOOL_VISION_PIXEL_LOOP std::size_t countAtLeast(const int* m, int count, int t2, int& strongest)
{
  std::size_t above = 0;
  int largest = strongest;
  for (int x = 0; x < count; ++x)
  {
    above += m[x] >= t2 ? 1u : 0u;
    largest = std::max(largest, m[x]);
  }
  strongest = largest;
  return above;
}

// Flags (0 or 1 per pixel or cell) passed over in one test where none is set: one 64-bit word, the
// lowest byte the leftmost.
constexpr int kFlagWord = 8;
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "forEachFlag() reads its flags as little-endian words");

// Calls visit(x) for each x in [0, count) whose flag is set, in rising order; `flags` holds count
// flags and then a word of zeros. Most pixels of a row are unflagged: a word of them costs one test.
template <typename Visit>
void forEachFlag(const std::uint8_t* flags, int count, Visit&& visit)
{
  for (int block = 0; block < count; block += kFlagWord)
  {
    std::uint64_t word = 0;
    std::memcpy(&word, flags + block, sizeof(word));
    while (word != 0)
    {
      visit(block + __builtin_ctzll(word) / 8);
      word &= word - 1;
    }
  }
}

// out[x] = 1 where m[x] reaches t2, else 0, for x in [0, count) (a per-pixel loop: AVX2 where the
// CPU has it).
SPOOL_VISION_PIXEL_LOOP void markAtLeast(const int* m, int count, int t2, std::uint8_t* out)
{
  for (int x = 0; x < count; ++x)
    out[x] = m[x] >= t2 ? 1 : 0;
}

// out[x] = 1 where row[x] is at least `floor` and a maximum of its 3x3 neighbourhood (up, row, down:
// ties with the cells before it in scan order count, ties with those after it do not), for x in
// [1, cols - 1); out[0] and out[cols - 1] are left as they are (a per-cell loop: AVX2 where the CPU
// has it).
SPOOL_VISION_PIXEL_LOOP void markPeaks(const float* up, const float* row, const float* down, int cols, float floor,
                                       std::uint8_t* out)
{
  for (int x = 1; x + 1 < cols; ++x)
  {
    const float v = row[x];
    // `&`, not `&&`: no branch per cell.
    const bool peak = (v >= floor) & (v >= row[x - 1]) & (v > row[x + 1]) & (v >= up[x - 1]) & (v >= up[x]) &
                      (v >= up[x + 1]) & (v > down[x - 1]) & (v > down[x]) & (v > down[x + 1]);
    out[x] = peak ? 1 : 0;
  }
}

// Unit-circle samples computed once, cosines and sines apart: visibleRimFraction() runs for every
// radius bin of every peak, and its loops vectorise over plain arrays.
struct UnitCircle
{
  std::array<double, kRimSamples> cos, sin;
};

const UnitCircle& unitCircle()
{
  static const UnitCircle kUnit = []
  {
    UnitCircle unit;
    for (std::size_t i = 0; i < kRimSamples; ++i)
    {
      const double a = (static_cast<double>(i) + 0.5) * 2.0 * kPi / kRimSamples;
      unit.cos[i] = std::cos(a);
      unit.sin[i] = std::sin(a);
    }
    return unit;
  }();
  return kUnit;
}

// How many of the kRimSamples points of the circle (x, y, r) lie in [-0.5, max_x] x [-0.5, max_y]
// (a per-sample loop: AVX2 where the CPU has it; each point computed alike either way).
SPOOL_VISION_PIXEL_LOOP int samplesInImage(const double* cos, const double* sin, double x, double y, double r,
                                           double max_x, double max_y)
{
  int inside = 0;
  for (std::size_t i = 0; i < kRimSamples; ++i)
  {
    const double px = x + r * cos[i];
    const double py = y + r * sin[i];
    // `&`, not `&&`: no branch per sample.
    const bool in_image = (px >= -0.5) & (px <= max_x) & (py >= -0.5) & (py <= max_y);
    inside += in_image ? 1 : 0;
  }
  return inside;
}
}  // namespace

double visibleRimFraction(double x, double y, double r, cv::Size image_size, const BackFlange& back)
{
  // Whole circle inside: the common case needs no sampling.
  if (back.growth <= 0.0 && x - r >= -0.5 && y - r >= -0.5 && x + r <= image_size.width - 0.5 &&
      y + r <= image_size.height - 0.5)
    return 1.0;
  const UnitCircle& unit = unitCircle();
  const double max_x = image_size.width - 0.5;
  const double max_y = image_size.height - 0.5;
  if (back.growth <= 0.0)
    return static_cast<double>(samplesInImage(unit.cos.data(), unit.sin.data(), x, y, r, max_x, max_y)) / kRimSamples;
  int inside = 0;
  for (std::size_t i = 0; i < kRimSamples; ++i)
  {
    const double px = x + r * unit.cos[i];
    const double py = y + r * unit.sin[i];
    // `&`, not `&&`: no branch per sample.
    const bool in_image = (px >= -0.5) & (px <= max_x) & (py >= -0.5) & (py <= max_y);
    inside += in_image && !back.hides(x, y, r, px, py) ? 1 : 0;
  }
  return static_cast<double>(inside) / kRimSamples;
}

bool RimMoments::fitCircle(double& x, double& y, double& r) const
{
  // Kasa fit, u^2 + v^2 + a u + b v + c = 0, from its normal equations.
  Eigen::Matrix3d n;
  n << suu, suv, su, suv, svv, sv, su, sv, count;
  const Eigen::Vector3d rhs(-(suuu + suvv), -(suuv + svvv), -(suu + svv));
  const Eigen::Vector3d abc = n.ldlt().solve(rhs);
  x = -abc(0) / 2.0;
  y = -abc(1) / 2.0;
  const double rr = x * x + y * y - abc(2);
  if (!(rr > 0.0))
    return false;
  r = std::sqrt(rr);
  return true;
}

bool RimMoments::fitEllipse(double& x, double& y, double& semi_x, double& semi_y) const
{
  // It needs the rim on the left and the right of the centre and most octants. Octants within
  // 45 degrees of the horizontal axis: u < 0 is 2 and 6, u >= 0 is 0 and 4.
  const bool left = octants & ((1u << 2) | (1u << 6));
  const bool right = octants & ((1u << 0) | (1u << 4));
  if (!left || !right || std::bitset<8>(octants).count() < 5)
    return false;
  // A u^2 + B v^2 + C u + D v = 1, from its normal equations.
  Eigen::Matrix4d n;
  n << suuuu, suuvv, suuu, suuv, suuvv, svvvv, suvv, svvv, suuu, suvv, suu, suv, suuv, svvv, suv, svv;
  const Eigen::Vector4d sol = n.ldlt().solve(Eigen::Vector4d(suu, svv, su, sv));
  if (!(sol(0) > 0.0 && sol(1) > 0.0))
    return false;
  x = -sol(2) / (2.0 * sol(0));
  y = -sol(3) / (2.0 * sol(1));
  const double k = 1.0 + sol(0) * x * x + sol(1) * y * y;
  if (!(k > 0.0))
    return false;
  semi_x = std::sqrt(k / sol(0));
  semi_y = std::sqrt(k / sol(1));
  return true;
}

void EdgeDetector::computeGradients(const cv::Mat& gray8)
{
  computeGradientsIn(gray8, cv::Rect(0, 0, gray8.cols, gray8.rows));
}

void EdgeDetector::computeGradientsIn(const cv::Mat& gray8, const cv::Rect& inner)
{
  // cv::Sobel allocates its filter engine on every call; this path reuses its buffers.
  gx_.create(gray8.size(), CV_16S);
  gy_.create(gray8.size(), CV_16S);
  mag_.create(gray8.size(), CV_32S);
  column_sum_.resize(static_cast<std::size_t>(gray8.cols + 2));
  column_diff_.resize(static_cast<std::size_t>(gray8.cols + 2));
  // The suppression reads the magnitude 1 px around an edge, the Sobel 1 px around that: over a
  // rectangle 2 px wider, whose own border replicates, `inner` and 1 px around it come out as in
  // the whole frame (whose border replicates the same way).
  const cv::Rect padded =
      cv::Rect(inner.x - 2, inner.y - 2, inner.width + 4, inner.height + 4) & cv::Rect(0, 0, gray8.cols, gray8.rows);
  cv::Mat gx = gx_(padded);
  cv::Mat gy = gy_(padded);
  cv::Mat mag = mag_(padded);
  sobel(gray8(padded), column_sum_.data(), column_diff_.data(), gx, gy, mag);
  computed_ = inner;
}

void EdgeDetector::detect(const cv::Mat& gray8, double threshold, std::size_t max_edges, std::vector<EdgePoint>& edges)
{
  detect(gray8, threshold, max_edges, edges, cv::Rect(0, 0, gray8.cols, gray8.rows));
}

void EdgeDetector::detect(const cv::Mat& gray8, double threshold, std::size_t max_edges, std::vector<EdgePoint>& edges,
                          const cv::Rect& region)
{
  const cv::Rect inner = region & cv::Rect(0, 0, gray8.cols, gray8.rows);
  computeGradientsIn(gray8, inner);
  extractRaw(threshold, inner, max_edges, edges, nullptr);
}

void EdgeDetector::computeGradients(const cv::Mat& gray8, const cv::Rect& region)
{
  computeGradientsIn(gray8, region & cv::Rect(0, 0, gray8.cols, gray8.rows));
}

void EdgeDetector::setUndistortion(const CameraIntrinsics& camera)
{
  lens_ = camera;
  if (camera.distorted())
    undistortionTable(camera, undistorted_);
  else
    undistorted_.release();
}

cv::Rect EdgeDetector::rawRoi(const cv::Rect& roi, cv::Size size) const
{
  if (undistorted_.empty() || undistorted_.size() != size)
    return roi;
  if ((roi & cv::Rect(0, 0, size.width, size.height)) == cv::Rect(0, 0, size.width, size.height))
    return roi;  // the whole frame (its undistorted image reaches beyond the rectangle)
  // A lens bends the rectangle's sides: their corners and midpoints bound it.
  double x0 = 1e300;
  double y0 = 1e300;
  double x1 = -1e300;
  double y1 = -1e300;
  for (const double fx : {0.0, 0.5, 1.0})
    for (const double fy : {0.0, 0.5, 1.0})
    {
      const cv::Point2d p = distortPixel(lens_, {roi.x + fx * roi.width, roi.y + fy * roi.height});
      x0 = std::min(x0, p.x);
      y0 = std::min(y0, p.y);
      x1 = std::max(x1, p.x);
      y1 = std::max(y1, p.y);
    }
  constexpr int kPad = 2;  // px, the bulge of a bent side between its samples
  return {cvFloor(x0) - kPad, cvFloor(y0) - kPad, cvCeil(x1 - x0) + 2 * kPad + 1, cvCeil(y1 - y0) + 2 * kPad + 1};
}

void EdgeDetector::undistort(std::vector<EdgePoint>& edges) const
{
  const int w = undistorted_.cols;
  const int h = undistorted_.rows;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < edges.size(); ++i)
  {
    const EdgePoint e = edges[i];
    const int x = std::clamp(cvRound(e.x), 0, w - 1);
    const int y = std::clamp(cvRound(e.y), 0, h - 1);
    const cv::Vec2f* row = undistorted_.ptr<cv::Vec2f>(y);
    const int xl = std::max(x - 1, 0);
    const int xr = std::min(x + 1, w - 1);
    const int yu = std::max(y - 1, 0);
    const int yd = std::min(y + 1, h - 1);
    // J = d(undistorted) / d(raw), columns by central differences of the table.
    const cv::Vec2f jx = (row[xr] - row[xl]) / static_cast<float>(xr - xl);
    const cv::Vec2f jy =
        (undistorted_.ptr<cv::Vec2f>(yd)[x] - undistorted_.ptr<cv::Vec2f>(yu)[x]) / static_cast<float>(yd - yu);
    const float ox = e.x - static_cast<float>(x);
    const float oy = e.y - static_cast<float>(y);
    const cv::Vec2f at = row[x] + jx * ox + jy * oy;
    // Gradient by J^-T (up to the positive 1/det, removed by the normalisation).
    const float gx = jy[1] * e.dx - jx[1] * e.dy;
    const float gy = -jy[0] * e.dx + jx[0] * e.dy;
    const float norm = std::sqrt(gx * gx + gy * gy);
    // Where a (wild) calibration has no inverse, undistortPoints diverges or the table folds: an
    // edge without a direction, or thrown further off the frame than the frame is large, is none.
    const bool placed = at[0] > -w && at[0] < 2.0f * w && at[1] > -h && at[1] < 2.0f * h;
    if (!placed || !(norm > 0.0f) || !std::isfinite(norm))
      continue;
    edges[kept++] = {at[0], at[1], gx / norm, gy / norm};
  }
  edges.resize(kept);
}

void EdgeDetector::extract(double threshold, const cv::Rect& roi, std::size_t max_edges, std::vector<EdgePoint>& edges,
                           const LinearLight* linear)
{
  extractRaw(threshold, rawRoi(roi, mag_.size()), max_edges, edges, linear);
}

void EdgeDetector::extractRaw(double threshold, const cv::Rect& raw, std::size_t max_edges,
                              std::vector<EdgePoint>& edges, const LinearLight* linear)
{
  edges.clear();
  strengths_.clear();
  // The outermost rows and columns have no neighbour on one side for the suppression.
  const cv::Rect area = raw & computed_ & cv::Rect(1, 1, mag_.cols - 2, mag_.rows - 2);
  const float t = static_cast<float>(std::max(threshold, 1e-3)) * kSobelFullScale;
  const int t2 = boundedThreshold(area, static_cast<int>(t * t), max_edges);
  const size_t step = mag_.step1();
  // A row's flags, then a whole word of zeros past its end.
  at_threshold_.assign(static_cast<std::size_t>(std::max(area.width, 0) + kFlagWord), 0);
  std::uint8_t* const flags = at_threshold_.data();
  for (int y = area.y; y < area.y + area.height; ++y)
  {
    const short* gxr = gx_.ptr<short>(y);
    const short* gyr = gy_.ptr<short>(y);
    const int* m = mag_.ptr<int>(y);
    markAtLeast(m + area.x, area.width, t2, flags);
    forEachFlag(flags, area.width,
                [&](int column)
                {
                  const int x = area.x + column;
                  const int c2 = m[x];
                  // Non-maximum suppression along the gradient, quantised to the 8-neighbourhood: a component
                  // counts where it is over sin(22.5 deg) of the magnitude, compared in squares (most pixels
                  // past the threshold are suppressed, and need no root or division).
                  const int gx = gxr[x];
                  const int gy = gyr[x];
                  const float counts = 0.3827f * 0.3827f * static_cast<float>(c2);
                  const int sx = static_cast<float>(gx * gx) > counts ? (gx > 0 ? 1 : -1) : 0;
                  const int sy = static_cast<float>(gy * gy) > counts ? (gy > 0 ? 1 : -1) : 0;
                  const std::ptrdiff_t offset_next =
                      sx + static_cast<std::ptrdiff_t>(sy) * static_cast<std::ptrdiff_t>(step);
                  const int before2 = m[x - offset_next];
                  const int after2 = m[x + offset_next];
                  if (c2 < before2 || c2 <= after2)
                    return;
                  const float c = std::sqrt(static_cast<float>(c2));
                  const float dx = static_cast<float>(gx) / c;
                  const float dy = static_cast<float>(gy) / c;
                  // Parabola through the three magnitudes puts the edge between pixels.
                  const float before = std::sqrt(static_cast<float>(before2));
                  const float after = std::sqrt(static_cast<float>(after2));
                  const float denom = before - 2.0f * c + after;
                  const float sub = denom < 0.0f ? 0.5f * (before - after) / denom : 0.0f;
                  edges.push_back({x + sub * sx, y + sub * sy, dx, dy});
                  strengths_.push_back(c2);
                });
  }
  if (edges.size() > max_edges)
    keepStrongest(max_edges, edges);
  if (linear && linear->gray && linear->gray->size() == mag_.size())
    placeInLinearLight(*linear, edges);
  if (!undistorted_.empty() && undistorted_.size() == mag_.size())
    undistort(edges);
}

int EdgeDetector::boundedThreshold(const cv::Rect& area, int t2, std::size_t max_edges)
{
  const std::size_t limit = max_edges > std::numeric_limits<std::size_t>::max() / kCandidatesPerEdge
                                ? std::numeric_limits<std::size_t>::max()
                                : kCandidatesPerEdge * max_edges;
  std::size_t above = 0;
  int strongest = t2;
  for (int y = area.y; y < area.y + area.height; ++y)
    above += countAtLeast(mag_.ptr<int>(y) + area.x, area.width, t2, strongest);
  if (above <= limit)
    return t2;
  const double bin_width = (static_cast<double>(strongest) - t2) / kMagnitudeBins + 1.0;
  magnitude_histogram_.assign(kMagnitudeBins, 0);
  for (int y = area.y; y < area.y + area.height; ++y)
  {
    const int* m = mag_.ptr<int>(y);
    for (int x = area.x; x < area.x + area.width; ++x)
      if (m[x] >= t2)
        ++magnitude_histogram_[static_cast<std::size_t>((m[x] - t2) / bin_width)];
  }
  // From the strongest bin down until the limit is reached; that bin's lower edge is the threshold.
  std::size_t kept = 0;
  for (int bin = kMagnitudeBins - 1; bin > 0; --bin)
  {
    kept += magnitude_histogram_[static_cast<std::size_t>(bin)];
    if (kept >= limit)
      return t2 + static_cast<int>(std::ceil(bin * bin_width));
  }
  return t2;
}

float linearLightAt(const LinearLight& linear, float x, float y)
{
  const cv::Mat& gray = *linear.gray;
  const float* table = linear.table;
  x = std::clamp(x, 0.0f, static_cast<float>(gray.cols - 1));
  y = std::clamp(y, 0.0f, static_cast<float>(gray.rows - 1));
  const int x0 = std::min(static_cast<int>(x), std::max(gray.cols - 2, 0));
  const int y0 = std::min(static_cast<int>(y), std::max(gray.rows - 2, 0));
  const int x1 = std::min(x0 + 1, gray.cols - 1);
  const int y1 = std::min(y0 + 1, gray.rows - 1);
  const float fx = x - static_cast<float>(x0);
  const float fy = y - static_cast<float>(y0);
  const uchar* top = gray.ptr<uchar>(y0);
  const uchar* bottom = gray.ptr<uchar>(y1);
  return (1.0f - fy) * ((1.0f - fx) * table[top[x0]] + fx * table[top[x1]]) +
         fy * ((1.0f - fx) * table[bottom[x0]] + fx * table[bottom[x1]]);
}

namespace
{

constexpr int kMaxHalfSteps = 16;

// Where the light crosses half-way between its dark and bright levels along edge `e`'s gradient
// near `at`: the offset (px) from `at`, read from 2 n + 1 half-pixel samples; NaN without one.
float halfLightCrossing(const LinearLight& linear, int n, const cv::Point2f& at, const EdgePoint& e)
{
  std::array<float, 2 * kMaxHalfSteps + 1> profile{};
  for (int k = -n; k <= n; ++k)
    profile[static_cast<std::size_t>(k + n)] = linearLightAt(linear, at.x + 0.5f * k * e.dx, at.y + 0.5f * k * e.dy);
  const float dark = 0.5f * (profile[0] + profile[1]);
  const float bright = 0.5f * (profile[static_cast<std::size_t>(2 * n)] + profile[static_cast<std::size_t>(2 * n - 1)]);
  float move = std::numeric_limits<float>::quiet_NaN();
  if (!(bright > dark))
    return move;
  const float half = 0.5f * (dark + bright);
  for (int k = 0; k < 2 * n; ++k)
  {
    const float a = profile[static_cast<std::size_t>(k)];
    const float b = profile[static_cast<std::size_t>(k + 1)];
    const float t = 0.5f * (static_cast<float>(k - n) + (half - a) / (b - a));
    if (a <= half && b > half && !(std::abs(t) >= std::abs(move)))
      move = t;
  }
  return move;
}
}  // namespace

void EdgeDetector::placeInLinearLight(const LinearLight& linear, std::vector<EdgePoint>& edges)
{
  // Half-pixel samples along the gradient (dark to light), kMaxHalfSteps each side at most.
  constexpr float kMaxMove = 2.0f;  // px: further off, the crossing belongs to another edge
  const int n = std::clamp(static_cast<int>(std::ceil(2.0 * linear.reach)), 2, kMaxHalfSteps);
  for (EdgePoint& e : edges)
  {
    // Read again about the moved point: the levels either side are then taken as far from the
    // edge on both sides, which a blur wider than the reach needs.
    cv::Point2f at(e.x, e.y);
    for (int pass = 0; pass < 2; ++pass)
    {
      const float move = halfLightCrossing(linear, n, at, e);
      if (!(std::abs(move) <= kMaxMove))
        break;
      at += cv::Point2f(move * e.dx, move * e.dy);
    }
    if (std::hypot(at.x - e.x, at.y - e.y) <= kMaxMove)
    {
      e.x = at.x;
      e.y = at.y;
    }
  }
}

void EdgeDetector::keepStrongest(std::size_t max_edges, std::vector<EdgePoint>& edges)
{
  // Over budget: keep the strongest max_edges, in their row-major order (ties at the cut are
  // taken first come).
  selection_.assign(strengths_.begin(), strengths_.end());
  const auto cut = selection_.end() - static_cast<std::ptrdiff_t>(max_edges);
  std::nth_element(selection_.begin(), cut, selection_.end());
  const int cutoff = *cut;
  std::size_t above = 0;
  for (const int s : strengths_)
    above += s > cutoff ? 1 : 0;
  std::size_t ties = max_edges - above;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < edges.size(); ++i)
  {
    const bool keep = strengths_[i] > cutoff || (strengths_[i] == cutoff && ties > 0);
    if (!keep)
      continue;
    ties -= strengths_[i] == cutoff ? 1 : 0;
    edges[kept] = edges[i];
    strengths_[kept++] = strengths_[i];
  }
  edges.resize(kept);
  strengths_.resize(kept);
}

void HoughAccumulator::vote(const std::vector<EdgePoint>& edges, const HoughSearch& search)
{
  // A rim of either polarity: every edge votes on both sides.
  const float polarity_sign = centreSign(search.polarity);
  if (polarity_sign == 0.0f)
  {
    for (const float sign : {1.0f, -1.0f})
      vote(edges, search, sign);
    return;
  }
  vote(edges, search, polarity_sign);
}

void HoughAccumulator::vote(const std::vector<EdgePoint>& edges, const HoughSearch& search, float sign)
{
  const float cell = static_cast<float>(cell_);
  const float inv_cell = 1.0f / cell;
  const int cols = votes_.cols;
  const int rows = votes_.rows;
  const int steps = radiusSteps(search);
  const float ox = static_cast<float>(origin_.x);
  const float oy = static_cast<float>(origin_.y);
  const float r0 = static_cast<float>(search.r_min);
  float* data = votes_.ptr<float>();
  // 1/r weighting makes a full circle worth ~2*pi whatever its size; one weight per radius step,
  // shared by every edge (a division per vote cost a fifth of the voting).
  vote_weights_.resize(static_cast<std::size_t>(steps));
  float r = r0;
  for (int i = 0; i < steps; ++i, r += cell)
    vote_weights_[static_cast<std::size_t>(i)] = cell / r;
  const float* weight = vote_weights_.data();
  vote_cells_.resize(static_cast<std::size_t>(steps));
  castVotes(edges.data(), edges.size(), sign, r0, inv_cell, {ox, oy}, weight, steps, {cols, rows}, vote_cells_.data(),
            data);
}

int HoughAccumulator::radiusSteps(const HoughSearch& search) const
{
  return std::max(1, static_cast<int>(std::ceil((search.r_max - search.r_min) / cell_)) + 1);
}

void HoughAccumulator::findPeaks(const HoughSearch& search, int max_peaks, const cv::Rect2d& centres)
{
  peaks_.clear();
  // 3x3 binomial smoothing (zero border) spreads each vote over its neighbours, so a centre
  // whose votes straddle cells still forms one peak.
  smoothed_data_.resize(std::max(smoothed_data_.size(), votes_.total()));
  smoothed_ = cv::Mat(votes_.size(), CV_32F, smoothed_data_.data());
  // Only the border is cleared: every cell inside it is written below.
  const int last = votes_.cols - 1;
  std::fill(smoothed_.ptr<float>(0), smoothed_.ptr<float>(0) + votes_.cols, 0.0f);
  std::fill(smoothed_.ptr<float>(votes_.rows - 1), smoothed_.ptr<float>(votes_.rows - 1) + votes_.cols, 0.0f);
  for (int y = 1; y + 1 < votes_.rows; ++y)
  {
    const float* a = votes_.ptr<float>(y - 1);
    const float* b = votes_.ptr<float>(y);
    const float* c = votes_.ptr<float>(y + 1);
    float* out = smoothed_.ptr<float>(y);
    out[0] = 0.0f;
    out[last] = 0.0f;
    binomial3x3Row(a, b, c, votes_.cols, out);
  }
  // A rim supported over min_score of min_visible_fraction, with votes spread over a few cells.
  const float floor_votes = static_cast<float>(2.0 * kPi * search.min_score * search.min_visible_fraction * 0.25);
  // A row's flags (the first and last cells never set), then a whole word of zeros past its end.
  peak_flags_.assign(static_cast<std::size_t>(smoothed_.cols + kFlagWord), 0);
  for (int y = 1; y + 1 < smoothed_.rows; ++y)
  {
    const float* up = smoothed_.ptr<float>(y - 1);
    const float* row = smoothed_.ptr<float>(y);
    const float* down = smoothed_.ptr<float>(y + 1);
    markPeaks(up, row, down, smoothed_.cols, floor_votes, peak_flags_.data());
    forEachFlag(peak_flags_.data(), smoothed_.cols,
                [&](int x)
                {
                  const float v = row[x];
                  // Sub-cell centre from a parabola through the neighbours on each axis.
                  const float dxden = row[x - 1] - 2 * v + row[x + 1];
                  const float dyden = up[x] - 2 * v + down[x];
                  const float ox = dxden < 0 ? 0.5f * (row[x - 1] - row[x + 1]) / dxden : 0.0f;
                  const float oy = dyden < 0 ? 0.5f * (up[x] - down[x]) / dyden : 0.0f;
                  const cv::Point2d centre(origin_.x + (x + ox) * cell_, origin_.y + (y + oy) * cell_);
                  if (centres.empty() || centres.contains(centre))
                    peaks_.push_back({centre.x, centre.y, v});
                });
  }
  std::sort(peaks_.begin(), peaks_.end(), [](const Peak& a, const Peak& b) { return a.votes > b.votes; });
  // Greedy suppression: two centres closer than half the smallest radius are one circle.
  const double min_sep2 = std::pow(std::max(2.0 * cell_, 0.5 * search.r_min), 2);
  size_t kept = 0;
  for (size_t i = 0; i < peaks_.size() && static_cast<int>(kept) < max_peaks; ++i)
  {
    bool near = false;
    for (size_t j = 0; j < kept && !near; ++j)
      near = std::pow(peaks_[i].x - peaks_[j].x, 2) + std::pow(peaks_[i].y - peaks_[j].y, 2) < min_sep2;
    if (!near)
      peaks_[kept++] = peaks_[i];
  }
  peaks_.resize(kept);
}

bool HoughAccumulator::measureRadius(const std::vector<EdgePoint>& edges, cv::Size image_size,
                                     const HoughSearch& search, const Peak& peak, double slack, const BackFlange& back,
                                     Circle& circle)
{
  // An empty range (fitAt() about a flange larger than the search allows) has no rim.
  if (!(search.r_max >= search.r_min))
    return false;
  const double lo = std::max(1.0, search.r_min - slack);
  const double hi = search.r_max + slack;
  const int bins = static_cast<int>(std::ceil(hi - lo)) + 1;
  // Spare bins after the last take the edges that support no radius (radiusBins()).
  histogram_.assign(static_cast<size_t>(bins + kSpareBins), 0.0f);
  if (support_bins_.size() < edges.size())
    support_bins_.resize(edges.size());
  radiusBins(edges.data(), edges.size(), {static_cast<float>(peak.x), static_cast<float>(peak.y)},
             static_cast<float>(lo), static_cast<float>(hi), centreSign(search.polarity), bins, support_bins_.data());
  for (std::size_t i = 0; i < edges.size(); ++i)
    histogram_[support_bins_[i]] += 1.0f;

  double best_score = scoreRadii(image_size, search, peak, lo, bins, slack, back);
  if (best_score <= 0.0)
    return false;
  // Among the radii scoring close to the best, the largest wins: ribs and labels are concentric
  // but smaller than the rim. Unless a back flange is modelled, whose crescent would be the
  // outer ring: then the best-scoring one.
  const std::vector<double>& scores = scores_;
  double best_r = 0.0;
  for (int i = bins - 2; i >= 1; --i)
  {
    if (scores[static_cast<size_t>(i)] >= (back.growth > 0.0 ? 1.0 : 0.8) * best_score)
    {
      // Take the local maximum at or just inside the first strong radius from outside.
      int j = i;
      while (j > 1 && scores[static_cast<size_t>(j - 1)] > scores[static_cast<size_t>(j)])
        --j;
      best_r = lo + j;
      best_score = scores[static_cast<size_t>(j)];
      break;
    }
  }
  circle.x = peak.x;
  circle.y = peak.y;
  circle.r = best_r;
  circle.r_vertical = circle.r_horizontal = best_r;
  circle.score = std::min(1.0, best_score);
  circle.visible_fraction = visibleRimFraction(peak.x, peak.y, best_r, image_size);
  return true;
}

double HoughAccumulator::scoreRadii(cv::Size image_size, const HoughSearch& search, const Peak& peak, double lo,
                                    int bins, double slack, const BackFlange& back)
{
  double best_score = 0.0;
  scores_.assign(static_cast<size_t>(bins), 0.0);
  // A centre known to `slack` px spreads a rim over as many bins: each radius sums the bins
  // within half of that (at least one each side), so a big rim found from a coarse cell is not
  // outscored by a sharper ring inside it.
  const int half = std::max(1, static_cast<int>(std::lround(0.5 * slack)));
  for (int i = 1; i + 1 < bins; ++i)
  {
    const double r = lo + i;
    if (r < search.r_min || r > search.r_max)
      continue;
    double support = 0.0;
    for (int k = std::max(0, i - half); k <= std::min(bins - 1, i + half); ++k)
      support += histogram_[static_cast<size_t>(k)];
    if (support < 3.0)
      continue;
    const double vis = visibleRimFraction(peak.x, peak.y, r, image_size);
    // The rim over the back flange cannot show; too little left to judge is no rim.
    const double can_show = back.growth > 0.0 ? visibleRimFraction(peak.x, peak.y, r, image_size, back) : vis;
    if (vis < search.min_visible_fraction || can_show < 0.5 * search.min_visible_fraction)
      continue;
    // Capped: a rim is at most fully supported; a double edge (a raised rib, noise) is no more.
    scores_[static_cast<size_t>(i)] = std::min(1.0, support / (2.0 * kPi * r * can_show));
    best_score = std::max(best_score, scores_[static_cast<size_t>(i)]);
  }
  return best_score;
}

void HoughAccumulator::gatherNear(const std::vector<EdgePoint>& edges, const cv::Point2d& centre, double inner,
                                  double outer, const cv::Point2d& side)
{
  const double inner2 = inner > 0.0 ? inner * inner : 0.0;
  const double outer2 = outer * outer;
  if (near_.size() < edges.size())
    near_.resize(edges.size());
  if (keep_.size() < edges.size())
    keep_.resize(edges.size());
  if (ellipse_weights_.size() < edges.size())
    ellipse_weights_.resize(edges.size());
  inAnnulus(edges.data(), edges.size(), centre, inner2, outer2, side, keep_.data());
  // Every edge is written and the count advances over the ones kept: no branch per edge.
  std::size_t kept = 0;
  for (std::size_t i = 0; i < edges.size(); ++i)
  {
    near_[kept] = edges[i];
    kept += keep_[i];
  }
  near_count_ = kept;
}

bool fitRimModel(const RimMoments& m, double mean_r, Circle& model)
{
  double ux = 0.0;
  double uy = 0.0;
  double ur = 0.0;
  if (!m.fitCircle(ux, uy, ur))
    return false;
  const double r_fit = ur * mean_r;
  Circle next = model;
  next.x = model.x + ux * mean_r;
  next.y = model.y + uy * mean_r;
  next.r = next.r_horizontal = next.r_vertical = r_fit;
  double ex = 0.0;
  double ey = 0.0;
  double sx = 0.0;
  double sy = 0.0;
  if (m.fitEllipse(ex, ey, sx, sy) && std::abs(sx * mean_r / r_fit - 1.0) < 0.2 &&
      std::abs(sy * mean_r / r_fit - 1.0) < 0.2)
  {
    next.x = model.x + ex * mean_r;
    next.y = model.y + ey * mean_r;
    next.r_horizontal = sx * mean_r;
    next.r_vertical = sy * mean_r;
  }
  model = next;
  return true;
}

std::size_t HoughAccumulator::pickBand(const Circle& model, double band, float sign)
{
  // The band test compares squares: no square root for points outside.
  const double semi_x = model.r_horizontal;
  const double semi_y = model.r_vertical;
  const double b = band / std::sqrt(semi_x * semi_y);
  const double rho_min2 = std::pow(std::max(0.0, 1.0 - b), 2);
  const double rho_max2 = std::pow(1.0 + b, 2);
  inEllipseBand(near_.data(), near_count_, {model.x, model.y}, 1.0 / (semi_x * semi_x), 1.0 / (semi_y * semi_y),
                rho_min2, rho_max2, sign, keep_.data());
  // Picked without a branch per edge: every index is written, the count advances over the kept.
  if (taken_.size() < near_count_)
    taken_.resize(near_count_);
  std::size_t n = 0;
  for (std::size_t i = 0; i < near_count_; ++i)
  {
    taken_[n] = static_cast<std::uint32_t>(i);
    n += keep_[i];
  }
  return n;
}

bool HoughAccumulator::fitPasses(cv::Size image_size, const HoughSearch& search, int first, Circle& model)
{
  const float sign = centreSign(search.polarity);
  std::size_t count = 0;
  for (int iteration = first; iteration <= kFits; ++iteration)
  {
    const double band = std::max(1.5, kFitBands[iteration] * model.r);
    count = pickBand(model, band, sign);
    if (iteration == kFits)
      break;
    if (count < 8)
      return false;
    // Rim points in coordinates centred and scaled on the model (for conditioning).
    const double mean_r = std::sqrt(model.r_horizontal * model.r_vertical);
    const double scale = 1.0 / mean_r;
    RimMoments m;
    for (std::size_t k = 0; k < count; ++k)
      m.add((near_[taken_[k]].x - model.x) * scale, (near_[taken_[k]].y - model.y) * scale);
    if (!fitRimModel(m, mean_r, model))
      return false;
  }
  model.visible_fraction = visibleRimFraction(model.x, model.y, model.r, image_size);
  if (model.visible_fraction < search.min_visible_fraction)
    return false;
  // Thin 8-connected edges put about 0.9 points per unit of arc length on a rim.
  model.score = std::min(1.0, static_cast<double>(count) / (0.9 * 2.0 * kPi * model.r * model.visible_fraction));
  return true;
}

cv::Point3d HoughAccumulator::mostSupportedNear(const Circle& start, double reach, float sign)
{
  const double band = std::max(1.5, kFitBands[kNarrowPass] * start.r);
  const double lo = std::max(1.0, (1.0 - kRefitSizeReach) * start.r);
  const double hi = (1.0 + kRefitSizeReach) * start.r;
  const int bins = static_cast<int>(std::ceil(hi - lo)) + 1;
  const int half = std::max(1, static_cast<int>(std::lround(band)));
  if (support_bins_.size() < near_count_)
    support_bins_.resize(near_count_);
  cv::Point3d best(start.x, start.y, start.r);
  double best_support = -1.0;
  auto search_grid = [&](const cv::Point2d& around, double extent, double step)
  {
    const int steps = static_cast<int>(std::ceil(extent / step));
    for (int iy = -steps; iy <= steps; ++iy)
      for (int ix = -steps; ix <= steps; ++ix)
      {
        const cv::Point2f c(static_cast<float>(around.x + step * ix), static_cast<float>(around.y + step * iy));
        histogram_.assign(static_cast<size_t>(bins + kSpareBins), 0.0f);
        radiusBins(near_.data(), near_count_, c, static_cast<float>(lo), static_cast<float>(hi), sign, bins,
                   support_bins_.data());
        for (std::size_t i = 0; i < near_count_; ++i)
          histogram_[support_bins_[i]] += 1.0f;
        double window = 0.0;
        for (int k = 0; k < std::min(bins, 2 * half + 1); ++k)
          window += histogram_[static_cast<size_t>(k)];
        for (int i = half; i + half < bins; ++i)
        {
          if (i > half)
            window += histogram_[static_cast<size_t>(i + half)] - histogram_[static_cast<size_t>(i - half - 1)];
          // Support per unit of radius: a larger circle is not favoured for its longer rim.
          const double support = window / (lo + i);
          if (support > best_support)
          {
            best_support = support;
            best = cv::Point3d(c.x, c.y, lo + i);
          }
        }
      }
  };
  const double coarse = std::max(1.0, 0.25 * reach);
  search_grid({start.x, start.y}, reach, coarse);
  search_grid({best.x, best.y}, coarse, 1.0);
  return best;
}

bool HoughAccumulator::refine(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                              Circle& circle)
{
  Circle model = circle;
  model.r_horizontal = model.r_vertical = circle.r;
  // Only edges near the starting circle can join the fit (a fit that moves further has lost its
  // rim): gathered once, so the passes below do not each walk every edge of the frame.
  const double reach = 2.0 * std::max(1.5, kFitBands[0] * circle.r) + 2.0;
  gatherNear(edges, {circle.x, circle.y}, circle.r - reach, circle.r + reach, {});
  if (!fitPasses(image_size, search, 0, model))
    return false;
  circle = model;
  return model.r >= search.r_min * 0.9 && model.r <= search.r_max * 1.1;
}

bool HoughAccumulator::refitOnMostSupport(const std::vector<EdgePoint>& edges, cv::Size image_size,
                                          const HoughSearch& search, Circle& circle)
{
  const double reach = kRefitCentreReach * circle.r;
  const double band = std::max(1.5, kFitBands[kNarrowPass] * circle.r);
  gatherNear(edges, {circle.x, circle.y}, (1.0 - kRefitSizeReach) * circle.r - reach - band,
             (1.0 + kRefitSizeReach) * circle.r + reach + band, {});
  const cv::Point3d most = mostSupportedNear(circle, reach, centreSign(search.polarity));
  Circle model = circle;
  model.x = most.x;
  model.y = most.y;
  model.r = model.r_horizontal = model.r_vertical = most.z;
  // Only the narrow passes: the wide first band would take the arcs beside the rim in again.
  if (!fitPasses(image_size, search, kNarrowPass, model))
    return false;
  circle = model;
  return true;
}

bool HoughAccumulator::fitAt(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                             const cv::Point2d& centre, const BackFlange& back, Circle& circle)
{
  // The centre is given: the histogram needs no slack for a coarse accumulator cell.
  if (!measureRadius(edges, image_size, search, {centre.x, centre.y, 0.0f}, 1.0, back, circle))
    return false;
  const float sign = centreSign(search.polarity);
  const double band = std::max(1.5, 0.025 * circle.r);  // refine()'s final band
  double sum = 0.0;
  int count = 0;
  for (int pass = 0; pass < 2; ++pass)
  {
    // First the mean distance of the supporting edges, then their count about that radius.
    const double r = pass == 0 ? circle.r : sum / count;
    sum = 0.0;
    count = 0;
    for (const EdgePoint& e : edges)
    {
      const double vx = e.x - centre.x;
      const double vy = e.y - centre.y;
      const double d2 = vx * vx + vy * vy;
      const double d = std::sqrt(d2);
      // Adding zero leaves the sum as it was: no branch per edge.
      const bool aligned = radial(vx, vy, d2, e, sign);
      const bool supports = (std::abs(d - r) <= band) & aligned;
      sum += supports ? d : 0.0;
      count += supports ? 1 : 0;
    }
    if (count == 0)
      return false;
    circle.r = circle.r_vertical = circle.r_horizontal = r;
  }
  circle.visible_fraction = visibleRimFraction(centre.x, centre.y, circle.r, image_size);
  const double can_show = visibleRimFraction(centre.x, centre.y, circle.r, image_size, back);
  circle.score = std::min(1.0, count / (0.9 * 2.0 * kPi * circle.r * std::max(can_show, 1e-3)));
  return circle.visible_fraction >= search.min_visible_fraction;
}

HoughAccumulator::EllipseForm::EllipseForm(const EllipseShape& shape) : mean_r(std::sqrt(shape.semi_x * shape.semi_y))
{
  const double c = std::cos(shape.tilt);
  const double s = std::sin(shape.tilt);
  const double ix2 = 1.0 / (shape.semi_x * shape.semi_x);
  const double iy2 = 1.0 / (shape.semi_y * shape.semi_y);
  xx = c * c * ix2 + s * s * iy2;
  xy = 2.0 * c * s * (ix2 - iy2);
  yy = s * s * ix2 + c * c * iy2;
}

double HoughAccumulator::ellipseSupport(const cv::Point2d& c, const EllipseForm& form, double band, float sign,
                                        int* count) const
{
  ellipseWeights(near_.data(), near_count_, c, form.xx, form.xy, form.yy, form.mean_r, band, sign,
                 ellipse_weights_.data());
  double soft = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < near_count_; ++i)
  {
    const double w = ellipse_weights_[i];
    const bool supports = w >= 0.0;
    soft += supports ? w : 0.0;
    n += supports ? 1 : 0;
  }
  if (count)
    *count = n;
  return soft;
}

namespace
{
// The centre within `reach` px of `start` that `score` rates highest: grids of 1, 0.3, 0.06 and
// 0.02 px (the first `grids` of them), each reaching a little beyond half the step before it (a
// soft support peaks smoothly over its band, so its best point is within half a step of the
// optimum).
template <typename Score>
cv::Point2d searchCentre(const cv::Point2d& start, double reach, Score score, double& best_score, int grids = 4)
{
  cv::Point2d best = start;
  best_score = -1.0;
  auto search_grid = [&](const cv::Point2d& around, double extent, double step)
  {
    const cv::Point2d from = around;  // a copy: `around` may be `best`, which moves below
    const int steps = static_cast<int>(std::ceil(extent / step));
    for (int iy = -steps; iy <= steps; ++iy)
      for (int ix = -steps; ix <= steps; ++ix)
      {
        const cv::Point2d c(from.x + step * ix, from.y + step * iy);
        const double value = score(c);
        if (value > best_score)
        {
          best_score = value;
          best = c;
        }
      }
  };
  search_grid(start, reach, 1.0);
  constexpr std::array<std::array<double, 2>, 3> kFiner{{{0.6, 0.3}, {0.2, 0.06}, {0.04, 0.02}}};
  for (int i = 0; i + 1 < grids && i < static_cast<int>(kFiner.size()); ++i)
    search_grid(best, kFiner[static_cast<std::size_t>(i)][0], kFiner[static_cast<std::size_t>(i)][1]);
  return best;
}
}  // namespace

cv::Point2d HoughAccumulator::bestCentre(const cv::Point2d& start, const EllipseShape& shape, double band,
                                         double max_shift, float sign, double& best_soft, int grids) const
{
  const EllipseForm form(shape);
  return searchCentre(
      start, max_shift, [&](const cv::Point2d& c) { return ellipseSupport(c, form, band, sign, nullptr); }, best_soft,
      grids);
}

double HoughAccumulator::bestScaleAt(const cv::Point2d& c, const EllipseForm& form, double lo, int steps, float sign,
                                     double& scale)
{
  // ellipseSupport() at every scale s in one pass: an edge at normalised radius rho is off the
  // scaled ellipse by |rho - s| mean_r px.
  const double mean_r = form.mean_r;
  auto band_at = [&](int k) { return std::max(0.75, 0.04 * (lo + k * kScaleStep) * mean_r); };
  const double widest = band_at(steps) / mean_r;
  scale_soft_.assign(static_cast<std::size_t>(steps) + 1, 0.0);
  for (std::size_t i = 0; i < near_count_; ++i)
  {
    const EdgePoint& e = near_[i];
    const double vx = e.x - c.x;
    const double vy = e.y - c.y;
    if (!radial(vx, vy, vx * vx + vy * vy, e, sign))
      continue;
    const double rho = std::sqrt(form.rho2(vx, vy));
    const int first = std::max(0, static_cast<int>(std::ceil((rho - widest - lo) / kScaleStep)));
    const int last = std::min(steps, static_cast<int>(std::floor((rho + widest - lo) / kScaleStep)));
    for (int k = first; k <= last; ++k)
    {
      const double band = band_at(k);
      const double off = std::abs(rho - (lo + k * kScaleStep)) * mean_r;
      if (off <= band)
        scale_soft_[static_cast<std::size_t>(k)] += 1.0 - off / band;
    }
  }
  // Soft support per px of rim and of band: a larger ellipse is not favoured for its length, nor a
  // wider band for catching more.
  double best = -1.0;
  for (int k = 0; k <= steps; ++k)
  {
    const double s = lo + k * kScaleStep;
    const double density = scale_soft_[static_cast<std::size_t>(k)] / (s * mean_r * band_at(k));
    if (density > best)
    {
      best = density;
      scale = s;
    }
  }
  return best;
}

bool HoughAccumulator::fitCentreAtSize(const std::vector<EdgePoint>& edges, cv::Size image_size,
                                       const HoughSearch& search, const cv::Point2d& start, const EllipseShape& shape,
                                       double max_shift, const cv::Point2d& side, Circle& circle)
{
  const double mean_r = std::sqrt(shape.semi_x * shape.semi_y);
  const double band = std::max(0.75, 0.04 * mean_r);
  gatherNear(edges, start, std::min(shape.semi_x, shape.semi_y) - max_shift - band,
             std::max(shape.semi_x, shape.semi_y) + max_shift + band, side);
  double soft = 0.0;
  return supportAt(image_size, search, bestCentre(start, shape, band, max_shift, centreSign(search.polarity), soft),
                   shape, side, circle);
}

bool HoughAccumulator::fitCentreAndScale(const std::vector<EdgePoint>& edges, cv::Size image_size,
                                         const HoughSearch& search, const cv::Point2d& start, const EllipseShape& shape,
                                         double max_shift, const cv::Point2d& side, double lo, double hi,
                                         Circle& circle)
{
  const double mean_r = std::sqrt(shape.semi_x * shape.semi_y);
  const double smallest = std::min(shape.semi_x, shape.semi_y);
  const double largest = std::max(shape.semi_x, shape.semi_y);
  gatherNear(edges, start, lo * smallest - max_shift - 0.04 * hi * mean_r - 0.75,
             hi * largest + max_shift + 0.04 * hi * mean_r + 0.75, side);
  const float sign = centreSign(search.polarity);
  const int steps = static_cast<int>(std::floor((hi - lo) / kScaleStep + 1e-9));
  double scale = 1.0;
  double density = 0.0;
  const EllipseForm form(shape);
  const cv::Point2d best_centre = searchCentre(
      start, max_shift, [&](const cv::Point2d& c) { return bestScaleAt(c, form, lo, steps, sign, scale); }, density);
  double best_scale = 1.0;
  bestScaleAt(best_centre, form, lo, steps, sign, best_scale);
  const double band = std::max(0.75, 0.04 * best_scale * mean_r);
  gatherNear(edges, best_centre, best_scale * smallest - band, best_scale * largest + band, side);
  return supportAt(image_size, search, best_centre, shape.scaled(best_scale), side, circle);
}

double HoughAccumulator::shapeDensity(const std::vector<EdgePoint>& edges, const HoughSearch& search,
                                      const cv::Point2d& start, const EllipseShape& shape, double max_shift)
{
  const double mean_r = std::sqrt(shape.semi_x * shape.semi_y);
  const double band = std::max(0.75, 0.04 * mean_r);
  gatherNear(edges, start, std::min(shape.semi_x, shape.semi_y) - max_shift - band,
             std::max(shape.semi_x, shape.semi_y) + max_shift + band, {});
  // The centre to 0.3 px (two grids): shapes compared differ by 10% and more where it matters,
  // and the finer grids change a density by under 1%.
  double soft = 0.0;
  bestCentre(start, shape, band, max_shift, centreSign(search.polarity), soft, 2);
  const double a = shape.semi_x;
  const double b = shape.semi_y;
  const double perimeter = kPi * (3.0 * (a + b) - std::sqrt((3.0 * a + b) * (a + 3.0 * b)));
  return perimeter > 0.0 ? std::max(0.0, soft) / perimeter : 0.0;
}

bool HoughAccumulator::supportAt(cv::Size image_size, const HoughSearch& search, const cv::Point2d& centre,
                                 const EllipseShape& shape, const cv::Point2d& side, Circle& circle) const
{
  const double mean_r = std::sqrt(shape.semi_x * shape.semi_y);
  const double band = std::max(0.75, 0.04 * mean_r);
  int count = 0;
  ellipseSupport(centre, EllipseForm(shape), band, centreSign(search.polarity), &count);
  if (count < 8)
    return false;
  circle.x = centre.x;
  circle.y = centre.y;
  circle.r = 0.5 * (shape.semi_x + shape.semi_y);
  circle.r_vertical = shape.halfHeight();
  circle.r_horizontal = shape.halfWidth();
  circle.visible_fraction = visibleRimFraction(centre.x, centre.y, circle.r, image_size);
  const double arc = side == cv::Point2d() ? 1.0 : 0.5;
  circle.score = std::min(1.0, count / (0.9 * 2.0 * kPi * mean_r * arc * std::max(circle.visible_fraction, 1e-3)));
  return true;
}

void HoughAccumulator::detect(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                              std::vector<Circle>& circles)
{
  circles.clear();
  voted_ = search;
  has_votes_ = false;
  if (search.r_max <= 0.0 || search.r_max < search.r_min || edges.empty())
    return;

  // Cells coarse enough to keep the accumulator small for big radii, fine for small ones.
  cell_ = std::clamp(search.r_min / 16.0, 0.25, 8.0);
  cv::Rect2d window = search.center_window;
  if (window.empty())
  {
    // Centres off the image still leave min_visible_fraction of the rim in view.
    const double margin = search.r_max * std::cos(kPi * search.min_visible_fraction);
    window = cv::Rect2d(-margin, -margin, image_size.width + 2 * margin, image_size.height + 2 * margin);
  }
  // One cell of border keeps the peak test and the smoothing away from the window's edge.
  origin_ = cv::Point2d(window.x - cell_, window.y - cell_);
  const int cols = static_cast<int>(std::ceil(window.width / cell_)) + 3;
  const int rows = static_cast<int>(std::ceil(window.height / cell_)) + 3;
  // The spare cells after the accumulator take castVotes()'s votes off it.
  votes_data_.resize(std::max(votes_data_.size(), static_cast<size_t>(rows) * static_cast<size_t>(cols) +
                                                      static_cast<size_t>(radiusSteps(search))));
  votes_ = cv::Mat(rows, cols, CV_32F, votes_data_.data());
  std::fill(votes_.ptr<float>(), votes_.ptr<float>() + votes_.total(), 0.0f);  // setTo allocates

  vote(edges, search);
  has_votes_ = true;
  circlesFromVotes(edges, image_size, search, {}, circles);
}

void HoughAccumulator::requireVotesOf(const HoughSearch& search, const char* caller) const
{
  if (search.r_min != voted_.r_min || search.r_max != voted_.r_max || search.center_window != voted_.center_window ||
      search.polarity != voted_.polarity)
    throw std::logic_error(std::string("HoughAccumulator::") + caller + ": the last detect() was of another search");
}

void HoughAccumulator::detectAgain(const std::vector<EdgePoint>& edges, cv::Size image_size, const HoughSearch& search,
                                   const cv::Rect2d& centres, std::vector<Circle>& circles)
{
  requireVotesOf(search, "detectAgain");
  circles.clear();
  if (has_votes_)
    circlesFromVotes(edges, image_size, search, centres, circles);
}

void HoughAccumulator::detectEitherPolarity(const std::vector<EdgePoint>& edges, cv::Size image_size,
                                            const HoughSearch& search, const cv::Rect2d& centres,
                                            std::vector<Circle>& circles)
{
  requireVotesOf(search, "detectEitherPolarity");
  circles.clear();
  if (!has_votes_)
    return;  // detect() found nothing to vote with
  HoughSearch either = search;
  either.polarity = Polarity::kAny;
  if (search.polarity != Polarity::kAny)
  {
    vote(edges, search, -centreSign(search.polarity));
    voted_ = either;
  }
  circlesFromVotes(edges, image_size, either, centres, circles);
}

void HoughAccumulator::circlesFromVotes(const std::vector<EdgePoint>& edges, cv::Size image_size,
                                        const HoughSearch& search, const cv::Rect2d& centres,
                                        std::vector<Circle>& circles)
{
  findPeaks(search, 2 * search.max_circles, centres);

  for (const Peak& peak : peaks_)
  {
    Circle circle;
    // The centre is known to about a cell; the radius histogram must tolerate that much.
    if (!measureRadius(edges, image_size, search, peak, cell_ + 1.0, {}, circle))
      continue;
    const bool windowed = !search.center_window.empty();
    if (!windowed && circle.score < kMinRefineSupport * search.min_score)
      continue;
    const Circle measured = circle;
    if (!refine(edges, image_size, search, circle) ||
        (windowed && !search.center_window.contains(cv::Point2d(circle.x, circle.y))))
    {
      // A fit can slide off a faint rim onto a stronger edge beside it (a small bore's front rim
      // onto the see-through lens inside it). Where the window already pins the centre (a hole
      // concentric with its flange), the measured circle stands in; elsewhere the peak is dropped.
      if (!windowed)
        continue;
      circle = measured;
    }
    if (circle.score < search.min_score)
      continue;
    // Two peaks can refine onto the same rim; keep the first (stronger) one.
    const bool duplicate = std::any_of(circles.begin(), circles.end(),
                                       [&](const Circle& c) {
                                         return std::hypot(c.x - circle.x, c.y - circle.y) < 0.25 * circle.r &&
                                                std::abs(c.r - circle.r) < 0.1 * circle.r;
                                       });
    if (!duplicate)
      circles.push_back(circle);
  }
  std::sort(circles.begin(), circles.end(), [](const Circle& a, const Circle& b) { return a.score > b.score; });
  if (static_cast<int>(circles.size()) > search.max_circles)
    circles.resize(static_cast<size_t>(search.max_circles));
}

}  // namespace spool_vision
