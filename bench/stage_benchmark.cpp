// The two per-frame stages the core writes by hand instead of calling OpenCV, timed against the
// OpenCV calls that do the same job on the same rendered frame at each size the webcam streams:
//  - the Gaussian (Preprocessor::filter with the default filter_sigma) against cv::GaussianBlur
//    with the same sigma, kernel size and replicated border;
//  - the 3x3 Sobel with its squared magnitude (EdgeDetector::computeGradients) against
//    cv::spatialGradient (OpenCV's fused 3x3 Sobel pair) and the squared magnitude in CV_32S.
// Both hand-written stages reuse their buffers; cv::GaussianBlur builds a filter engine and
// allocates on every call, which the detector's no-allocation promise (test_allocations) forbids
// on its own. The figures say what the hand-written code buys in time (README, Benchmark).
// Once per camera, not per frame: the lens table (undistortionTable: the model solved on a grid,
// interpolated between) against solving every pixel with cv::undistortPoints, as it was built
// before, for a C270-like lens at 640x480 and 1280x720 (the bar: 20 ms at 1280x720).
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "spool_vision/camera_model.h"
#include "spool_vision/detector_params.h"
#include "spool_vision/eval/evaluation.h"
#include "spool_vision/hough_accumulator.h"
#include "spool_vision/preprocessor.h"
#include "spool_vision/render/spool_renderer.h"

namespace sv = spool_vision;

namespace
{
// One rendered main-set frame as 8-bit gray, and the camera it was taken with.
struct GrayFrame
{
  cv::Mat gray;
  sv::CameraIntrinsics camera;
};

GrayFrame frameAt(const benchmark::State& state)
{
  const cv::Size size(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  GrayFrame f;
  f.camera = sv::CameraIntrinsics::thesisDefault(size.width, size.height);
  const sv::SpoolRenderer renderer(f.camera);
  const sv::RenderedFrame frame = sv::renderSet(renderer, sv::FrameSet::kMain, 1, 1).front();
  sv::Preprocessor::toGray(frame.image, sv::PixelFormat::kBgr8, f.gray);
  return f;
}

// The detector's Gaussian: its sigma in px and the kernel radius its taps reach (3 sigma).
double sigmaPx(const GrayFrame& f)
{
  return sv::DetectorParams().preprocess.filter_sigma * f.camera.fy;
}

void gaussianOurs(benchmark::State& state)
{
  const GrayFrame f = frameAt(state);
  sv::Preprocessor preprocessor(sv::DetectorParams().preprocess, f.camera.fy);
  cv::Mat out;
  for (auto _ : state)
  {
    preprocessor.filter(f.gray, out);
    benchmark::DoNotOptimize(out.data);
  }
}

void gaussianOpenCv(benchmark::State& state)
{
  const GrayFrame f = frameAt(state);
  const double sigma = sigmaPx(f);
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  cv::Mat out;
  for (auto _ : state)
  {
    cv::GaussianBlur(f.gray, out, cv::Size(2 * radius + 1, 2 * radius + 1), sigma, sigma, cv::BORDER_REPLICATE);
    benchmark::DoNotOptimize(out.data);
  }
}

void sobelOurs(benchmark::State& state)
{
  const GrayFrame f = frameAt(state);
  sv::EdgeDetector edges;
  for (auto _ : state)
  {
    edges.computeGradients(f.gray);
    benchmark::ClobberMemory();
  }
}

void sobelOpenCv(benchmark::State& state)
{
  const GrayFrame f = frameAt(state);
  cv::Mat gx;
  cv::Mat gy;
  cv::Mat gx32;
  cv::Mat gy32;
  cv::Mat magnitude;
  for (auto _ : state)
  {
    cv::spatialGradient(f.gray, gx, gy, 3, cv::BORDER_REPLICATE);
    gx.convertTo(gx32, CV_32S);
    gy.convertTo(gy32, CV_32S);
    magnitude = gx32.mul(gx32) + gy32.mul(gy32);
    benchmark::DoNotOptimize(magnitude.data);
  }
}
// A C270-like lens (k1 about -0.2) at the benchmark's size.
sv::CameraIntrinsics lensAt(const benchmark::State& state)
{
  sv::CameraIntrinsics camera =
      sv::CameraIntrinsics::thesisDefault(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  camera.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  return camera;
}

void lensTableOurs(benchmark::State& state)
{
  const sv::CameraIntrinsics camera = lensAt(state);
  cv::Mat table;
  for (auto _ : state)
  {
    sv::undistortionTable(camera, table);
    benchmark::DoNotOptimize(table.data);
  }
}

void lensTableEveryPixel(benchmark::State& state)
{
  const sv::CameraIntrinsics camera = lensAt(state);
  const cv::Matx33d k(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  cv::Mat raw(camera.height * camera.width, 1, CV_32FC2);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x)
      raw.at<cv::Vec2f>(y * camera.width + x) = cv::Vec2f(static_cast<float>(x), static_cast<float>(y));
  cv::Mat table;
  for (auto _ : state)
  {
    cv::undistortPoints(raw, table, k, camera.distortion, cv::noArray(), k,
                        cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0.0));
    benchmark::DoNotOptimize(table.data);
  }
}
}  // namespace

int main(int argc, char** argv)
{
  cv::setNumThreads(1);  // one core, as the detector runs
  using Stage = void (*)(benchmark::State&);
  for (const auto& [name, fn] :
       std::vector<std::pair<const char*, Stage>>{{"Gaussian/ours", &gaussianOurs},
                                                  {"Gaussian/cv::GaussianBlur", &gaussianOpenCv},
                                                  {"Sobel/ours", &sobelOurs},
                                                  {"Sobel/cv::spatialGradient", &sobelOpenCv}})
  {
    benchmark::internal::Benchmark* b = benchmark::RegisterBenchmark(name, fn);
    for (const auto& [width, height] : std::vector<std::pair<int, int>>{{160, 120}, {320, 240}, {640, 480}})
      b->Args({width, height});
    b->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);
  }
  for (const auto& [name, fn] : std::vector<std::pair<const char*, Stage>>{
           {"LensTable/ours", &lensTableOurs}, {"LensTable/cv::undistortPoints every pixel", &lensTableEveryPixel}})
  {
    benchmark::internal::Benchmark* b = benchmark::RegisterBenchmark(name, fn);
    for (const auto& [width, height] : std::vector<std::pair<int, int>>{{640, 480}, {1280, 720}})
      b->Args({width, height});
    b->Unit(benchmark::kMillisecond)->Repetitions(3)->ReportAggregatesOnly(true);
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
