#include "spool_vision/preprocessor.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "cpu_dispatch.h"

namespace spool_vision
{
namespace
{
cv::Mat diskElement(int radius)
{
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
}

// Separable blur of gray (CV_8U) into out (CV_8U, same size) with replicated borders in 16-bit
// fixed point: k[-radius..radius] are 8.8 taps summing to 256; rows (CV_16U), line (cols +
// 2 radius) and acc (cols) are scratch. The compiler vectorises both passes (the float version
// took twice as long). Rows keep 8 fraction bits, the vertical pass 16, rounded once at the end.
SPOOL_VISION_PIXEL_LOOP void separableBlur(const cv::Mat& gray, const std::uint16_t* k, int radius,
                                           std::uint16_t* line_buffer, cv::Mat& rows, std::uint32_t* acc_buffer,
                                           cv::Mat& out)
{
  const int w = gray.cols;
  const int h = gray.rows;
  for (int y = 0; y < h; ++y)
  {
    const uchar* in = gray.ptr<uchar>(y);
    std::uint16_t* line = line_buffer;
    for (int x = 0; x < radius; ++x)
    {
      line[x] = in[0];
      line[radius + w + x] = in[w - 1];
    }
    for (int x = 0; x < w; ++x)
      line[radius + x] = in[x];
    // Symmetric taps: one multiply per pair of pixels.
    std::uint16_t* row = rows.ptr<std::uint16_t>(y);
    const std::uint16_t* centre = line + radius;
    for (int x = 0; x < w; ++x)
      row[x] = static_cast<std::uint16_t>(k[0] * centre[x]);
    for (int t = 1; t <= radius; ++t)
    {
      const std::uint16_t wt = k[t];
      const std::uint16_t* left = centre - t;
      const std::uint16_t* right = centre + t;
      for (int x = 0; x < w; ++x)
        row[x] = static_cast<std::uint16_t>(row[x] + wt * (left[x] + right[x]));
    }
  }
  for (int y = 0; y < h; ++y)
  {
    std::uint32_t* acc = acc_buffer;
    const std::uint16_t* centre = rows.ptr<std::uint16_t>(y);
    for (int x = 0; x < w; ++x)
      acc[x] = static_cast<std::uint32_t>(centre[x]) * k[0];
    for (int t = 1; t <= radius; ++t)
    {
      const std::uint32_t wt = k[t];
      const std::uint16_t* above = rows.ptr<std::uint16_t>(std::max(y - t, 0));
      const std::uint16_t* below = rows.ptr<std::uint16_t>(std::min(y + t, h - 1));
      for (int x = 0; x < w; ++x)
        acc[x] += (static_cast<std::uint32_t>(above[x]) + below[x]) * wt;
    }
    uchar* dst = out.ptr<uchar>(y);
    for (int x = 0; x < w; ++x)
      dst[x] = static_cast<uchar>((acc[x] + 32768u) >> 16);
  }
}

// The top-left `size` of `buffer` (of `type`), which grows to hold it and never shrinks: a search
// window's size changes every frame, and the per-frame path must not allocate.
cv::Mat scratch(cv::Mat& buffer, cv::Size size, int type)
{
  if (buffer.type() != type || buffer.rows < size.height || buffer.cols < size.width)
    buffer.create(std::max(buffer.rows, size.height), std::max(buffer.cols, size.width), type);
  return buffer(cv::Rect(cv::Point(), size));
}
}  // namespace

Preprocessor::Preprocessor(const PreprocessParams& params, double focal_length)
{
  setParams(params, focal_length);
}

void Preprocessor::setParams(const PreprocessParams& params, double focal_length)
{
  params_ = params;
  structuring_element_ = diskElement(params_.morphology_radius);
  for (std::size_t level = 0; level < linear_light_.size(); ++level)
    linear_light_[level] = static_cast<float>(std::pow(level / 255.0, 1.0 / params_.encoding_gamma));
  // Gaussian taps out to 3 sigma in 8.8 fixed point, summing to exactly 256 (the centre tap
  // takes the rounding), so a flat image stays flat.
  const double sigma = params_.filter_sigma * focal_length;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  std::vector<double> weights(static_cast<size_t>(radius + 1));
  double sum = 0.0;
  for (int i = 0; i <= radius; ++i)
    sum += (i == 0 ? 1.0 : 2.0) * (weights[static_cast<size_t>(i)] = std::exp(-0.5 * i * i / (sigma * sigma)));
  kernel_.assign(static_cast<size_t>(2 * radius + 1), 0);
  int total = 0;
  for (int i = 1; i <= radius; ++i)
  {
    const auto w = static_cast<std::uint16_t>(std::lround(256.0 * weights[static_cast<size_t>(i)] / sum));
    kernel_[static_cast<size_t>(radius - i)] = kernel_[static_cast<size_t>(radius + i)] = w;
    total += 2 * w;
  }
  kernel_[static_cast<size_t>(radius)] = static_cast<std::uint16_t>(256 - total);
}

void Preprocessor::gaussian(const cv::Mat& gray, cv::Mat& out)
{
  // Written out so that the per-frame path reuses its buffers (cv::GaussianBlur allocates on every
  // call).
  const int radius = static_cast<int>(kernel_.size() / 2);
  cv::Mat rows = scratch(rows_, gray.size(), CV_16U);
  line_.resize(static_cast<size_t>(gray.cols + 2 * radius));
  acc_.resize(static_cast<size_t>(gray.cols));
  out.create(gray.size(), CV_8U);
  separableBlur(gray, kernel_.data() + radius, radius, line_.data(), rows, acc_.data(), out);
}

int Preprocessor::filterReach() const
{
  switch (params_.filter)
  {
    case FilterType::kGaussian:
    case FilterType::kUnsharp:
      return static_cast<int>(kernel_.size() / 2);
    case FilterType::kMedian:
    case FilterType::kAverage:
      return params_.filter_kernel / 2;
    case FilterType::kNone:
      return 0;
  }
  return 0;
}

namespace
{
void checkFrame(const cv::Mat& image, PixelFormat format)
{
  if (image.empty())
    throw std::invalid_argument("empty image");
  if (image.type() != matTypeOf(format))
    throw std::invalid_argument("image type " + cv::typeToString(image.type()) +
                                " does not match its pixel format (expected " + cv::typeToString(matTypeOf(format)) +
                                ")");
}

// cv::cvtColor's codes from `format` to gray (ITU-R BT.601 luma) and to BGR; -1 where no
// cv::cvtColor does it (8-bit grey and BGR are copied, 16-bit grey is scaled).
struct ColourCodes
{
  int to_gray;
  int to_bgr;
};

ColourCodes colourCodes(PixelFormat format)
{
  switch (format)
  {
    case PixelFormat::kMono8:
      return {-1, cv::COLOR_GRAY2BGR};
    case PixelFormat::kMono16:
      return {-1, -1};
    case PixelFormat::kBgr8:
      return {cv::COLOR_BGR2GRAY, -1};
    case PixelFormat::kRgb8:
      return {cv::COLOR_RGB2GRAY, cv::COLOR_RGB2BGR};
    case PixelFormat::kBgra8:
      return {cv::COLOR_BGRA2GRAY, cv::COLOR_BGRA2BGR};
    case PixelFormat::kRgba8:
      return {cv::COLOR_RGBA2GRAY, cv::COLOR_RGBA2BGR};
  }
  return {-1, -1};
}

// cv::cvtColor on the calling thread. OpenCV splits a frame's rows among its worker threads (TBB
// on Debian) but runs a range of one row in place, so the frame goes through as one row (or row
// by row when strided). The per-frame path stays on its caller's thread: the speed bars are per
// core, and a worker thread's start allocates and delays the frame. Pixels are the same.
void convertColour(const cv::Mat& src, cv::Mat& dst, int code)
{
  if (src.isContinuous() && dst.isContinuous())
  {
    cv::Mat dst_row = dst.reshape(0, 1);
    cv::cvtColor(src.reshape(0, 1), dst_row, code);
    return;
  }
  for (int y = 0; y < src.rows; ++y)
  {
    cv::Mat dst_row = dst.row(y);
    cv::cvtColor(src.row(y), dst_row, code);
  }
}
}  // namespace

void Preprocessor::toGray(const cv::Mat& image, PixelFormat format, cv::Mat& gray)
{
  checkFrame(image, format);
  gray.create(image.size(), CV_8U);
  if (format == PixelFormat::kMono16)
    image.convertTo(gray, CV_8U, 1.0 / 257.0);  // 65535 -> 255
  else if (const int code = colourCodes(format).to_gray; code >= 0)
    convertColour(image, gray, code);
  else
    image.copyTo(gray);
}

void Preprocessor::toBgr(const cv::Mat& image, PixelFormat format, cv::Mat& bgr)
{
  checkFrame(image, format);
  if (format == PixelFormat::kMono16)
  {
    cv::Mat mono8;
    toGray(image, format, mono8);
    bgr.create(image.size(), CV_8UC3);
    convertColour(mono8, bgr, cv::COLOR_GRAY2BGR);
  }
  else if (const int code = colourCodes(format).to_bgr; code >= 0)
  {
    bgr.create(image.size(), CV_8UC3);
    convertColour(image, bgr, code);
  }
  else
    image.copyTo(bgr);
}

void Preprocessor::filter(const cv::Mat& gray, cv::Mat& out)
{
  const int k = params_.filter_kernel;
  switch (params_.filter)
  {
    case FilterType::kGaussian:
      gaussian(gray, out);
      break;
    case FilterType::kMedian:
      cv::medianBlur(gray, out, k);
      break;
    case FilterType::kAverage:
      cv::blur(gray, out, cv::Size(k, k), cv::Point(-1, -1), cv::BORDER_REPLICATE);
      break;
    case FilterType::kUnsharp:
    {
      // out = gray + amount * (gray - blur(gray)), saturated to 8 bit.
      cv::Mat blur = scratch(blur_, gray.size(), CV_8U);
      gaussian(gray, blur);
      cv::addWeighted(gray, 1.0 + params_.unsharp_amount, blur, -params_.unsharp_amount, 0.0, out);
      break;
    }
    case FilterType::kNone:
      gray.copyTo(out);
      break;
  }
}

void Preprocessor::binarize(const cv::Mat& gray, cv::Mat& out) const
{
  switch (params_.binarize)
  {
    case BinarizeType::kFixed:
      // MATLAB im2bw: a pixel is white when strictly above level * full scale.
      cv::threshold(gray, out, params_.binarize_threshold * 255.0, 255, cv::THRESH_BINARY);
      break;
    case BinarizeType::kOtsu:
      cv::threshold(gray, out, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
      break;
    case BinarizeType::kNone:
      gray.copyTo(out);
      break;
  }
}

void Preprocessor::morphology(const cv::Mat& binary, cv::Mat& out) const
{
  if (params_.morphology == MorphologyType::kNone || params_.morphology_radius == 0)
  {
    binary.copyTo(out);
    return;
  }
  const int op = params_.morphology == MorphologyType::kOpen     ? cv::MORPH_OPEN
                 : params_.morphology == MorphologyType::kDilate ? cv::MORPH_DILATE
                                                                 : cv::MORPH_ERODE;
  cv::morphologyEx(binary, out, op, structuring_element_);
}

void Preprocessor::areaOpening(const cv::Mat& binary, cv::Mat& out)
{
  binary.copyTo(out);
  if (params_.min_component_area <= 0)
    return;
  const int n = cv::connectedComponentsWithStats(binary, labels_, stats_, centroids_, 8, CV_32S);
  for (int y = 0; y < out.rows; ++y)
  {
    const int* label = labels_.ptr<int>(y);
    uchar* pixel = out.ptr<uchar>(y);
    for (int x = 0; x < out.cols; ++x)
    {
      const int l = label[x];
      if (l > 0 && l < n && stats_.at<int>(l, cv::CC_STAT_AREA) < params_.min_component_area)
        pixel[x] = 0;
    }
  }
}

void Preprocessor::process(const cv::Mat& image, PixelFormat format, cv::Mat& out)
{
  toGray(image, format, gray_);
  filter(gray_, filtered_);
  if (params_.binarize == BinarizeType::kNone)
  {
    // Morphology and area opening are defined on binary images only.
    filtered_.copyTo(out);
    return;
  }
  binarize(filtered_, binary_);
  morphology(binary_, morph_);
  areaOpening(morph_, out);
}

void Preprocessor::process(const cv::Mat& image, PixelFormat format, cv::Mat& out, const cv::Rect& region)
{
  const cv::Rect frame(0, 0, image.cols, image.rows);
  const cv::Rect inner = region & frame;
  if (inner == frame || params_.binarize != BinarizeType::kNone)
  {
    process(image, format, out);
    return;
  }
  checkFrame(image, format);
  out.create(image.size(), CV_8U);
  out.setTo(0);
  if (inner.empty())
    return;  // a window wholly beyond the frame's border: nothing to search
  // The filter reads filterReach() px around each pixel: computed over the padded rectangle,
  // whose own border replicates, `inner` comes out as in the whole frame (the frame's border
  // replicates the same way where the padding meets it).
  const int reach = filterReach();
  const cv::Rect padded =
      cv::Rect(inner.x - reach, inner.y - reach, inner.width + 2 * reach, inner.height + 2 * reach) & frame;
  gray_.create(image.size(), CV_8U);
  filtered_.create(image.size(), CV_8U);
  cv::Mat gray = gray_(padded);
  toGray(image(padded), format, gray);
  cv::Mat filtered = filtered_(padded);
  filter(gray, filtered);
  filtered_(inner).copyTo(out(inner));
}

}  // namespace spool_vision
