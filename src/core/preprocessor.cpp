#include "spool_vision/preprocessor.h"

#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace spool_vision
{
namespace
{
int expectedType(PixelFormat format)
{
  switch (format)
  {
    case PixelFormat::kMono8:
      return CV_8UC1;
    case PixelFormat::kMono16:
      return CV_16UC1;
    case PixelFormat::kBgr8:
    case PixelFormat::kRgb8:
      return CV_8UC3;
    case PixelFormat::kBgra8:
    case PixelFormat::kRgba8:
      return CV_8UC4;
  }
  return -1;
}

cv::Mat diskElement(int radius)
{
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
}
}  // namespace

Preprocessor::Preprocessor(const PreprocessParams& params)
{
  setParams(params);
}

void Preprocessor::setParams(const PreprocessParams& params)
{
  params_ = params;
  structuring_element_ = diskElement(params_.morphology_radius);
}

void Preprocessor::toGray(const cv::Mat& image, PixelFormat format, cv::Mat& gray)
{
  if (image.empty())
    throw std::invalid_argument("empty image");
  if (image.type() != expectedType(format))
    throw std::invalid_argument("image type " + cv::typeToString(image.type()) +
                                " does not match its pixel format (expected " +
                                cv::typeToString(expectedType(format)) + ")");
  switch (format)
  {
    case PixelFormat::kMono8:
      image.copyTo(gray);
      break;
    case PixelFormat::kMono16:
      image.convertTo(gray, CV_8U, 1.0 / 257.0);
      break;
    case PixelFormat::kBgr8:
      cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
      break;
    case PixelFormat::kRgb8:
      cv::cvtColor(image, gray, cv::COLOR_RGB2GRAY);
      break;
    case PixelFormat::kBgra8:
      cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
      break;
    case PixelFormat::kRgba8:
      cv::cvtColor(image, gray, cv::COLOR_RGBA2GRAY);
      break;
  }
}

void Preprocessor::filter(const cv::Mat& gray, cv::Mat& out)
{
  const int k = params_.filter_kernel;
  switch (params_.filter)
  {
    case FilterType::kGaussian:
      cv::GaussianBlur(gray, out, cv::Size(), params_.filter_sigma, params_.filter_sigma,
                       cv::BORDER_REPLICATE);
      break;
    case FilterType::kMedian:
      cv::medianBlur(gray, out, k);
      break;
    case FilterType::kAverage:
      cv::blur(gray, out, cv::Size(k, k), cv::Point(-1, -1), cv::BORDER_REPLICATE);
      break;
    case FilterType::kUnsharp:
      // out = gray + amount * (gray - blur(gray)), saturated to 8 bit.
      cv::GaussianBlur(gray, blur_, cv::Size(), params_.filter_sigma, params_.filter_sigma,
                       cv::BORDER_REPLICATE);
      cv::addWeighted(gray, 1.0 + params_.unsharp_amount, blur_, -params_.unsharp_amount, 0.0,
                      out);
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
