// The threading policy of SpoolDetector::detect: the call runs on its caller's thread, OpenCV's
// worker pool included. OpenCV's parallel regions are routed through a backend of this test's
// (cv::parallel::ParallelForAPI) that counts them and runs them in place, with OpenCV set to two
// threads so that a frame would be split if the code asked for it. Its own executable: the
// backend is process-wide.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/parallel/parallel_backend.hpp>
#include <opencv2/imgproc.hpp>

#include "spool_vision/camera_model.h"
#include "spool_vision/preprocessor.h"
#include "spool_vision/spool_detector.h"
#include "synthetic.h"

namespace
{
using spool_vision::CameraIntrinsics;
using spool_vision::DetectorParams;
using spool_vision::PixelFormat;
using spool_vision::SpoolDetector;
namespace st = spool_vision::test;

class CountingBackend : public cv::parallel::ParallelForAPI
{
public:
  void parallel_for(int tasks, FN_parallel_for_body_cb_t body, void* data) override
  {
    ++regions;
    body(0, tasks, data);
  }
  int getThreadNum() const override
  {
    return 0;
  }
  int getNumThreads() const override
  {
    return threads_;
  }
  int setNumThreads(int threads) override
  {
    const int previous = threads_;
    threads_ = threads;
    return previous;
  }
  const char* getName() const override
  {
    return "counting";
  }

  std::atomic<int> regions{0};

private:
  int threads_ = 1;
};

CountingBackend& backend()
{
  static const std::shared_ptr<CountingBackend> instance = []
  {
    auto counting = std::make_shared<CountingBackend>();
    cv::parallel::setParallelForBackend(counting);
    cv::setNumThreads(2);  // two cores here; on one OpenCV never splits and the first test fails
    return counting;
  }();
  return *instance;
}

// OpenCV parallel regions opened by `work`.
template <typename Work>
int regionsIn(Work&& work)
{
  CountingBackend& counting = backend();
  counting.regions = 0;
  work();
  return counting.regions.load();
}

cv::Mat drawnSpool(const CameraIntrinsics& camera, cv::Size size)
{
  st::SceneStyle style;
  style.noise_sigma = 2.0;
  return st::drawScene(size, {st::spoolAt(camera, 0.8, 0.01, 0.06)}, style);
}

// `bgr` in `format`'s layout and matrix type.
cv::Mat inFormat(const cv::Mat& bgr, PixelFormat format)
{
  cv::Mat out;
  switch (format)
  {
    case PixelFormat::kMono8:
      cv::cvtColor(bgr, out, cv::COLOR_BGR2GRAY);
      break;
    case PixelFormat::kMono16:
      cv::cvtColor(bgr, out, cv::COLOR_BGR2GRAY);
      out.convertTo(out, CV_16U, 257.0);
      break;
    case PixelFormat::kBgr8:
      out = bgr.clone();
      break;
    case PixelFormat::kRgb8:
      cv::cvtColor(bgr, out, cv::COLOR_BGR2RGB);
      break;
    case PixelFormat::kBgra8:
      cv::cvtColor(bgr, out, cv::COLOR_BGR2BGRA);
      break;
    case PixelFormat::kRgba8:
      cv::cvtColor(bgr, out, cv::COLOR_BGR2RGBA);
      break;
  }
  return out;
}

const std::vector<PixelFormat> kFormats = {PixelFormat::kMono8, PixelFormat::kMono16, PixelFormat::kBgr8,
                                           PixelFormat::kRgb8,  PixelFormat::kBgra8,  PixelFormat::kRgba8};
}  // namespace

TEST(Threads, TheBackendSeesOpenCvSplittingAFrame)
{
  // A plain conversion of a 640x480 frame is split among the threads, or a zero below proves
  // nothing.
  const cv::Mat bgr(480, 640, CV_8UC3, cv::Scalar(10, 120, 250));
  cv::Mat gray;
  EXPECT_GT(regionsIn([&] { cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY); }), 0);
}

TEST(Threads, DetectRunsOnTheCallingThreadForEveryPixelFormatAndSize)
{
  for (const cv::Size size : {cv::Size(160, 120), cv::Size(640, 480), cv::Size(1280, 720)})
  {
    const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(size.width, size.height);
    const cv::Mat bgr = drawnSpool(camera, size);
    SpoolDetector detector;
    detector.setCamera(camera);
    for (const PixelFormat format : kFormats)
    {
      const cv::Mat frame = inFormat(bgr, format);
      bool detected = false;
      EXPECT_EQ(regionsIn([&] { detected = detector.detect(frame, format).detected; }), 0)
          << size << " format " << static_cast<int>(format);
      EXPECT_TRUE(detected) << size << " format " << static_cast<int>(format);
    }
  }
}

TEST(Threads, StridedFramesAndLensDistortionStayOnTheCallingThread)
{
  CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  camera.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  const cv::Mat wide = drawnSpool(CameraIntrinsics::thesisDefault(700, 480), {700, 480});
  const cv::Mat view = wide(cv::Rect(30, 0, 640, 480));  // rows 700 pixels apart
  ASSERT_FALSE(view.isContinuous());
  SpoolDetector detector;
  detector.setCamera(camera);  // the lens table: once per camera, not per frame
  EXPECT_EQ(regionsIn([&] { detector.detect(view, PixelFormat::kBgr8); }), 0);
}

TEST(Threads, TheOverlayConversionStaysOnTheCallingThread)
{
  const cv::Mat bgr = drawnSpool(CameraIntrinsics::thesisDefault(640, 480), {640, 480});
  for (const PixelFormat format : kFormats)
  {
    const cv::Mat frame = inFormat(bgr, format);
    cv::Mat out;
    EXPECT_EQ(regionsIn([&] { spool_vision::Preprocessor::toBgr(frame, format, out); }), 0)
        << "format " << static_cast<int>(format);
    ASSERT_EQ(out.type(), CV_8UC3);
    // Same pixels as OpenCV's own call on the whole frame.
    cv::Mat gray;
    spool_vision::Preprocessor::toGray(frame, format, gray);
    cv::Mat expected;
    cv::cvtColor(bgr, expected, cv::COLOR_BGR2GRAY);
    EXPECT_LE(cv::norm(gray, expected, cv::NORM_INF), format == PixelFormat::kMono16 ? 1.0 : 0.0)
        << "format " << static_cast<int>(format);
  }
}

TEST(Threads, GaussianUnsharpAndNoFilterStayOnTheCallingThread)
{
  // SpoolDetector::detect's docstring names the stages OpenCV may split (median, average, the
  // thesis' binarization and morphology); every other filter must not.
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(640, 480);
  const cv::Mat frame = drawnSpool(camera, {640, 480});
  for (const spool_vision::FilterType filter :
       {spool_vision::FilterType::kGaussian, spool_vision::FilterType::kUnsharp, spool_vision::FilterType::kNone})
  {
    DetectorParams params;
    params.preprocess.filter = filter;
    SpoolDetector detector(params);
    detector.setCamera(camera);
    EXPECT_EQ(regionsIn([&] { detector.detect(frame, PixelFormat::kBgr8); }), 0)
        << "filter " << static_cast<int>(filter);
  }
}
