#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "spool_vision/preprocessor.h"

using spool_vision::BinarizeType;
using spool_vision::FilterType;
using spool_vision::MorphologyType;
using spool_vision::PixelFormat;
using spool_vision::Preprocessor;
using spool_vision::PreprocessParams;

namespace
{
constexpr double kFocal = 200.0;  // px: filter_sigma is a view angle, sigma_px = filter_sigma * fy
}  // namespace

TEST(Preprocessor, GrayFromEveryPixelFormat)
{
  cv::Mat gray;
  // Pure red in BGR order is (0,0,255); read as RGB it would be pure blue.
  const cv::Mat red_bgr(4, 4, CV_8UC3, cv::Scalar(0, 0, 255));
  Preprocessor::toGray(red_bgr, PixelFormat::kBgr8, gray);
  EXPECT_NEAR(gray.at<uchar>(0, 0), 76, 1);  // 0.299 * 255
  Preprocessor::toGray(red_bgr, PixelFormat::kRgb8, gray);
  EXPECT_NEAR(gray.at<uchar>(0, 0), 29, 1);  // 0.114 * 255

  const cv::Mat red_bgra(4, 4, CV_8UC4, cv::Scalar(0, 0, 255, 255));
  Preprocessor::toGray(red_bgra, PixelFormat::kBgra8, gray);
  EXPECT_NEAR(gray.at<uchar>(0, 0), 76, 1);
  Preprocessor::toGray(red_bgra, PixelFormat::kRgba8, gray);
  EXPECT_NEAR(gray.at<uchar>(0, 0), 29, 1);

  const cv::Mat deep(4, 4, CV_16UC1, cv::Scalar(65535));
  Preprocessor::toGray(deep, PixelFormat::kMono16, gray);
  EXPECT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.at<uchar>(0, 0), 255);

  const cv::Mat mono(4, 4, CV_8UC1, cv::Scalar(42));
  Preprocessor::toGray(mono, PixelFormat::kMono8, gray);
  EXPECT_EQ(gray.at<uchar>(3, 3), 42);
}

TEST(Preprocessor, BgrCopyFromEveryPixelFormat)
{
  // Red in each colour layout, grey in each grey one: BGR red and BGR grey, in a buffer of its own.
  const cv::Vec3b red(0, 0, 255);
  const std::vector<std::tuple<cv::Mat, PixelFormat, cv::Vec3b>> cases = {
      {cv::Mat(4, 4, CV_8UC3, cv::Scalar(0, 0, 255)), PixelFormat::kBgr8, red},
      {cv::Mat(4, 4, CV_8UC3, cv::Scalar(255, 0, 0)), PixelFormat::kRgb8, red},
      {cv::Mat(4, 4, CV_8UC4, cv::Scalar(0, 0, 255, 255)), PixelFormat::kBgra8, red},
      {cv::Mat(4, 4, CV_8UC4, cv::Scalar(255, 0, 0, 255)), PixelFormat::kRgba8, red},
      {cv::Mat(4, 4, CV_8UC1, cv::Scalar(42)), PixelFormat::kMono8, cv::Vec3b(42, 42, 42)},
      {cv::Mat(4, 4, CV_16UC1, cv::Scalar(42 * 257)), PixelFormat::kMono16, cv::Vec3b(42, 42, 42)}};
  for (const auto& [image, format, expected] : cases)
  {
    cv::Mat bgr;
    Preprocessor::toBgr(image, format, bgr);
    ASSERT_EQ(bgr.type(), CV_8UC3) << static_cast<int>(format);
    EXPECT_EQ(bgr.at<cv::Vec3b>(3, 3), expected) << static_cast<int>(format);
    EXPECT_NE(bgr.data, image.data) << static_cast<int>(format);
  }
}

TEST(Preprocessor, RejectsMismatchedOrEmptyImages)
{
  cv::Mat gray;
  EXPECT_THROW(Preprocessor::toGray(cv::Mat(), PixelFormat::kMono8, gray), std::invalid_argument);
  EXPECT_THROW(Preprocessor::toGray(cv::Mat(4, 4, CV_8UC3), PixelFormat::kMono8, gray), std::invalid_argument);
  EXPECT_THROW(Preprocessor::toGray(cv::Mat(4, 4, CV_32FC1), PixelFormat::kMono16, gray), std::invalid_argument);
  EXPECT_THROW(Preprocessor::toBgr(cv::Mat(), PixelFormat::kBgr8, gray), std::invalid_argument);
  EXPECT_THROW(Preprocessor::toBgr(cv::Mat(4, 4, CV_8UC1), PixelFormat::kRgb8, gray), std::invalid_argument);
}

namespace
{
double noiseStddev(const cv::Mat& img)
{
  cv::Scalar mean;
  cv::Scalar stddev;
  cv::meanStdDev(img, mean, stddev);
  return stddev[0];
}
cv::Mat noisy()
{
  cv::Mat out(64, 64, CV_16S, cv::Scalar(128));
  cv::Mat signed_noise(64, 64, CV_16S);
  cv::RNG(7).fill(signed_noise, cv::RNG::NORMAL, 0, 20);
  out += signed_noise;
  out.convertTo(out, CV_8U);
  return out;
}
}  // namespace

TEST(Preprocessor, SmoothingFiltersReduceNoise)
{
  const cv::Mat in = noisy();
  const double before = noiseStddev(in);
  for (FilterType f : {FilterType::kGaussian, FilterType::kMedian, FilterType::kAverage})
  {
    PreprocessParams p;
    p.filter = f;
    p.filter_sigma = 2.0 / kFocal;
    p.filter_kernel = 5;
    Preprocessor pre(p, kFocal);
    cv::Mat out;
    pre.filter(in, out);
    EXPECT_LT(noiseStddev(out), 0.5 * before) << static_cast<int>(f);
  }
  PreprocessParams none;
  none.filter = FilterType::kNone;
  Preprocessor pre(none, kFocal);
  cv::Mat out;
  pre.filter(in, out);
  EXPECT_EQ(cv::norm(in, out, cv::NORM_INF), 0.0);
}

TEST(Preprocessor, UnsharpIncreasesEdgeContrast)
{
  cv::Mat step(16, 16, CV_8UC1, cv::Scalar(100));
  step(cv::Rect(8, 0, 8, 16)).setTo(150);
  PreprocessParams p;
  p.filter = FilterType::kUnsharp;
  p.filter_sigma = 1.0 / kFocal;
  p.unsharp_amount = 1.0;
  Preprocessor pre(p, kFocal);
  cv::Mat out;
  pre.filter(step, out);
  EXPECT_LT(out.at<uchar>(8, 7), 100);  // undershoot on the dark side
  EXPECT_GT(out.at<uchar>(8, 8), 150);  // overshoot on the bright side
  EXPECT_EQ(out.at<uchar>(8, 0), 100);  // flat areas unchanged
}

TEST(Preprocessor, FixedThresholdIsAFractionOfFullScale)
{
  PreprocessParams p;
  p.binarize = BinarizeType::kFixed;
  p.binarize_threshold = 0.35;  // 89.25 of 255
  Preprocessor pre(p, kFocal);
  cv::Mat in(1, 2, CV_8UC1);
  in.at<uchar>(0, 0) = 89;
  in.at<uchar>(0, 1) = 90;
  cv::Mat out;
  pre.binarize(in, out);
  EXPECT_EQ(out.at<uchar>(0, 0), 0);
  EXPECT_EQ(out.at<uchar>(0, 1), 255);
}

TEST(Preprocessor, OtsuSplitsABimodalImage)
{
  cv::Mat in(10, 10, CV_8UC1, cv::Scalar(40));
  in(cv::Rect(0, 0, 5, 10)).setTo(200);
  PreprocessParams p;
  p.binarize = BinarizeType::kOtsu;
  Preprocessor pre(p, kFocal);
  cv::Mat out;
  pre.binarize(in, out);
  EXPECT_EQ(out.at<uchar>(5, 2), 255);
  EXPECT_EQ(out.at<uchar>(5, 7), 0);
}

TEST(Preprocessor, MorphologyOpenRemovesSpecksKeepsDiscs)
{
  cv::Mat bin(40, 40, CV_8UC1, cv::Scalar(0));
  cv::circle(bin, {20, 20}, 8, cv::Scalar(255), cv::FILLED);
  bin.at<uchar>(3, 3) = 255;
  PreprocessParams p;
  p.morphology_radius = 2;
  cv::Mat out;
  p.morphology = MorphologyType::kOpen;
  Preprocessor(p, kFocal).morphology(bin, out);
  EXPECT_EQ(out.at<uchar>(3, 3), 0);
  EXPECT_EQ(out.at<uchar>(20, 20), 255);
  EXPECT_EQ(out.at<uchar>(20, 27), 255);

  p.morphology = MorphologyType::kDilate;
  Preprocessor(p, kFocal).morphology(bin, out);
  EXPECT_EQ(out.at<uchar>(20, 29), 255);  // grown by the radius
  p.morphology = MorphologyType::kErode;
  Preprocessor(p, kFocal).morphology(bin, out);
  EXPECT_EQ(out.at<uchar>(20, 27), 0);  // shrunk by the radius
}

TEST(Preprocessor, AreaOpeningDropsSmallComponents)
{
  cv::Mat bin(40, 40, CV_8UC1, cv::Scalar(0));
  bin(cv::Rect(2, 2, 5, 5)).setTo(255);    // 25 px
  bin(cv::Rect(20, 20, 6, 5)).setTo(255);  // 30 px
  PreprocessParams p;
  p.min_component_area = 30;
  Preprocessor pre(p, kFocal);
  cv::Mat out;
  pre.areaOpening(bin, out);
  EXPECT_EQ(out.at<uchar>(4, 4), 0);
  EXPECT_EQ(out.at<uchar>(22, 22), 255);
  EXPECT_EQ(cv::countNonZero(out), 30);
}

TEST(Preprocessor, ThesisChainProducesABinaryImage)
{
  PreprocessParams p;
  p.filter = FilterType::kGaussian;
  p.filter_sigma = 2.0 / kFocal;
  p.binarize = BinarizeType::kFixed;
  p.morphology = MorphologyType::kOpen;
  p.min_component_area = 30;
  Preprocessor pre(p, kFocal);
  cv::Mat out;
  pre.process(noisy(), PixelFormat::kMono8, out);
  ASSERT_EQ(out.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero((out != 0) & (out != 255)), 0);
}

TEST(Preprocessor, GaussianMatchesOpenCvsWithinTwoGreyLevels)
{
  // The fixed-point blur against cv::GaussianBlur (replicated borders) on a smooth random image.
  cv::Mat in(120, 160, CV_8U);
  cv::randu(in, 0, 256);
  cv::GaussianBlur(in, in, cv::Size(0, 0), 2.0);
  for (const double sigma_px : {1.5, 2.0})
  {
    PreprocessParams p;
    p.filter = FilterType::kGaussian;
    p.filter_sigma = sigma_px / kFocal;
    Preprocessor pre(p, kFocal);
    cv::Mat ours;
    pre.filter(in, ours);
    cv::Mat reference;
    cv::GaussianBlur(in, reference, cv::Size(0, 0), sigma_px, 0.0, cv::BORDER_REPLICATE);
    double worst = 0.0;
    cv::Mat diff;
    cv::absdiff(ours, reference, diff);
    cv::minMaxLoc(diff, nullptr, &worst);
    EXPECT_LE(worst, 2.0) << sigma_px;
    // A flat image stays flat: the taps sum to one exactly.
    cv::Mat flat(40, 40, CV_8U, cv::Scalar(201));
    pre.filter(flat, ours);
    EXPECT_EQ(cv::countNonZero(ours != 201), 0) << sigma_px;
  }
}

TEST(Preprocessor, ARegionHasTheWholeFramesPixelsInsideItAndNothingOutside)
{
  // A textured colour frame: every filter's reach crosses the region's sides.
  cv::Mat bgr(90, 120, CV_8UC3);
  cv::RNG(11).fill(bgr, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(bgr, bgr, cv::Size(), 1.5);
  cv::Mat mono;
  Preprocessor::toGray(bgr, PixelFormat::kBgr8, mono);
  // The last two miss the frame (a window predicted beyond its border): nothing inside, no error.
  const std::vector<cv::Rect> regions = {{30, 20, 50, 40}, {0, 0, 40, 35},    {90, 60, 100, 100},
                                         {-5, 70, 20, 40}, {130, 10, 20, 20}, {-40, -40, 20, 20}};
  for (FilterType f :
       {FilterType::kGaussian, FilterType::kUnsharp, FilterType::kMedian, FilterType::kAverage, FilterType::kNone})
  {
    PreprocessParams p;
    p.filter = f;
    p.filter_sigma = 2.0 / kFocal;
    p.filter_kernel = 5;
    Preprocessor pre(p, kFocal);
    for (const auto& [image, format] :
         {std::make_pair(bgr, PixelFormat::kBgr8), std::make_pair(mono, PixelFormat::kMono8)})
    {
      cv::Mat whole;
      pre.process(image, format, whole);
      for (const cv::Rect& region : regions)
      {
        cv::Mat part;
        pre.process(image, format, part, region);
        ASSERT_EQ(part.size(), image.size());
        const cv::Rect inside = region & cv::Rect(0, 0, image.cols, image.rows);
        EXPECT_EQ(cv::norm(whole(inside), part(inside), cv::NORM_INF), 0.0)
            << "filter " << static_cast<int>(f) << " region " << region;
        cv::Mat outside = part.clone();
        outside(inside).setTo(0);
        EXPECT_EQ(cv::countNonZero(outside), 0) << "filter " << static_cast<int>(f) << " region " << region;
      }
    }
  }
}
