#include "spool_vision/preprocessor.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace spool_vision
{
namespace
{
// ITU-R BT.601 luma in 14-bit fixed point (the weights cv::cvtColor uses).
template <int kChannels, int kRed, int kBlue>
void lumaRows(const cv::Mat& image, cv::Mat& gray)
{
  for (int y = 0; y < image.rows; ++y)
  {
    const uchar* in = image.ptr<uchar>(y);
    uchar* out = gray.ptr<uchar>(y);
    for (int x = 0; x < image.cols; ++x, in += kChannels)
      out[x] = static_cast<uchar>((in[kRed] * 4899 + in[1] * 9617 + in[kBlue] * 1868 + 8192) >> 14);
  }
}

cv::Mat diskElement(int radius)
{
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
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
  // Gaussian taps out to 3 sigma, normalised.
  const double sigma = params_.filter_sigma * focal_length;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  kernel_.resize(static_cast<size_t>(2 * radius + 1));
  float sum = 0.0f;
  for (int i = -radius; i <= radius; ++i)
    sum += kernel_[static_cast<size_t>(i + radius)] = static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& w : kernel_)
    w /= sum;
}

void Preprocessor::gaussian(const cv::Mat& gray, cv::Mat& out)
{
  // Separable blur with replicated borders, written out so that the per-frame path reuses
  // its buffers (cv::GaussianBlur allocates filter engines on every call).
  const int radius = static_cast<int>(kernel_.size() / 2);
  const int w = gray.cols;
  const int h = gray.rows;
  rows_.create(h, w, CV_32F);
  line_.resize(static_cast<size_t>(w + 2 * radius));
  acc_.resize(static_cast<size_t>(w));
  for (int y = 0; y < h; ++y)
  {
    const uchar* in = gray.ptr<uchar>(y);
    for (int x = -radius; x < w + radius; ++x)
      line_[static_cast<size_t>(x + radius)] = in[std::clamp(x, 0, w - 1)];
    // Symmetric taps: one multiply per pair of pixels.
    float* row = rows_.ptr<float>(y);
    const float* centre = line_.data() + radius;
    const float w0 = kernel_[static_cast<size_t>(radius)];
    for (int x = 0; x < w; ++x)
      row[x] = w0 * centre[x];
    for (int k = 1; k <= radius; ++k)
    {
      const float wk = kernel_[static_cast<size_t>(radius + k)];
      const float* left = centre - k;
      const float* right = centre + k;
      for (int x = 0; x < w; ++x)
        row[x] += wk * (left[x] + right[x]);
    }
  }
  out.create(h, w, CV_8U);
  for (int y = 0; y < h; ++y)
  {
    float* acc = acc_.data();
    const float* centre = rows_.ptr<float>(y);
    const float w0 = kernel_[static_cast<size_t>(radius)];
    for (int x = 0; x < w; ++x)
      acc[x] = 0.5f + w0 * centre[x];  // +0.5 rounds on the truncation below
    for (int k = 1; k <= radius; ++k)
    {
      const float wk = kernel_[static_cast<size_t>(radius + k)];
      const float* above = rows_.ptr<float>(std::max(y - k, 0));
      const float* below = rows_.ptr<float>(std::min(y + k, h - 1));
      for (int x = 0; x < w; ++x)
        acc[x] += wk * (above[x] + below[x]);
    }
    uchar* dst = out.ptr<uchar>(y);
    for (int x = 0; x < w; ++x)
      dst[x] = static_cast<uchar>(std::min(acc_[static_cast<size_t>(x)], 255.0f));
  }
}

void Preprocessor::toGray(const cv::Mat& image, PixelFormat format, cv::Mat& gray)
{
  if (image.empty())
    throw std::invalid_argument("empty image");
  if (image.type() != matTypeOf(format))
    throw std::invalid_argument("image type " + cv::typeToString(image.type()) +
                                " does not match its pixel format (expected " + cv::typeToString(matTypeOf(format)) +
                                ")");
  gray.create(image.size(), CV_8U);
  switch (format)
  {
    case PixelFormat::kMono8:
      image.copyTo(gray);
      break;
    case PixelFormat::kMono16:
      image.convertTo(gray, CV_8U, 1.0 / 257.0);
      break;
    case PixelFormat::kBgr8:
      lumaRows<3, 2, 0>(image, gray);
      break;
    case PixelFormat::kRgb8:
      lumaRows<3, 0, 2>(image, gray);
      break;
    case PixelFormat::kBgra8:
      lumaRows<4, 2, 0>(image, gray);
      break;
    case PixelFormat::kRgba8:
      lumaRows<4, 0, 2>(image, gray);
      break;
  }
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
      // out = gray + amount * (gray - blur(gray)), saturated to 8 bit.
      gaussian(gray, blur_);
      cv::addWeighted(gray, 1.0 + params_.unsharp_amount, blur_, -params_.unsharp_amount, 0.0, out);
      break;
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

}  // namespace spool_vision
