// The steady-state promise of SpoolDetector::detect (no heap allocation once the buffers fit the
// frame size and format), checked on every allocation of the process: this executable replaces
// the C allocator itself (glibc supports that: its own, OpenCV's, libstdc++'s and operator new's
// calls all come here), so an allocation inside OpenCV counts as much as a std::vector growing.
// Its own executable: the replacement must not slow or disturb the other suites.
#include <gtest/gtest.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <execinfo.h>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "spool_vision/camera_model.h"
#include "spool_vision/render/spool_renderer.h"
#include "spool_vision/spool_detector.h"
#include "synthetic.h"

extern "C"
{
  void* __libc_malloc(std::size_t size);
  void* __libc_calloc(std::size_t count, std::size_t size);
  void* __libc_realloc(void* p, std::size_t size);
  void* __libc_memalign(std::size_t alignment, std::size_t size);
  void __libc_free(void* p);
}

namespace
{
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
std::atomic<long> g_frees{0};
// The call stack of the first allocation counted, printed when a test fails (backtrace() does not
// allocate once it is loaded, which the first test does).
constexpr int kMaxFrames = 32;
void* g_first_stack[kMaxFrames];
int g_first_depth = 0;
thread_local bool t_inside = false;

void countAllocation()
{
  if (!g_counting || t_inside)
    return;
  if (g_allocations++ == 0)
  {
    t_inside = true;
    g_first_depth = backtrace(g_first_stack, kMaxFrames);
    t_inside = false;
  }
}

void countFree(void* p)
{
  if (p && g_counting && !t_inside)
    ++g_frees;
}
}  // namespace

// glibc declares these noexcept in C++.
extern "C"
{
  void* malloc(std::size_t size) noexcept
  {
    countAllocation();
    return __libc_malloc(size);
  }
  void* calloc(std::size_t count, std::size_t size) noexcept
  {
    countAllocation();
    return __libc_calloc(count, size);
  }
  void* realloc(void* p, std::size_t size) noexcept
  {
    countAllocation();
    return __libc_realloc(p, size);
  }
  void free(void* p) noexcept
  {
    countFree(p);
    __libc_free(p);
  }
  void* memalign(std::size_t alignment, std::size_t size) noexcept
  {
    countAllocation();
    return __libc_memalign(alignment, size);
  }
  void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept
  {
    countAllocation();
    return __libc_memalign(alignment, size);
  }
  int posix_memalign(void** p, std::size_t alignment, std::size_t size) noexcept
  {
    countAllocation();
    if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0)
      return 22;  // EINVAL
    *p = __libc_memalign(alignment, size);
    return *p ? 0 : 12;  // ENOMEM
  }
  void* valloc(std::size_t size) noexcept
  {
    countAllocation();
    return __libc_memalign(static_cast<std::size_t>(sysconf(_SC_PAGESIZE)), size);
  }
}

namespace
{
using spool_vision::CameraIntrinsics;
using spool_vision::DetectorParams;
using spool_vision::PixelFormat;
using spool_vision::SpoolDetection;
using spool_vision::SpoolDetector;
namespace st = spool_vision::test;

struct Counts
{
  long allocations;
  long frees;
};

// Heap calls made by `work`, counted over every thread.
template <typename Work>
Counts count(Work&& work)
{
  g_allocations = 0;
  g_frees = 0;
  g_first_depth = 0;
  g_counting = true;
  work();
  g_counting = false;
  return {g_allocations.load(), g_frees.load()};
}

void printFirstAllocation()
{
  if (g_first_depth > 0)
  {
    std::fputs("first allocation counted:\n", stderr);
    backtrace_symbols_fd(g_first_stack, g_first_depth, 2);
  }
}

constexpr int kWarmUpRounds = 2;  // every frame of the sequence, twice
constexpr int kFrames = 100;

// Frames of one size and format given in turn (a stream): after the warm-up, kFrames more calls
// must not touch the heap. Returns how many frames had a spool detected.
int expectSteadyState(SpoolDetector& detector, const std::vector<cv::Mat>& frames, PixelFormat format)
{
  for (int round = 0; round < kWarmUpRounds; ++round)
    for (const cv::Mat& frame : frames)
      detector.detect(frame, format);
  int detected = 0;
  const Counts counts = count(
      [&]
      {
        for (int i = 0; i < kFrames; ++i)
          detected += detector.detect(frames[static_cast<std::size_t>(i) % frames.size()], format).detected ? 1 : 0;
      });
  EXPECT_EQ(counts.allocations, 0) << "heap allocations in " << kFrames << " steady-state frames";
  EXPECT_EQ(counts.frees, 0) << "heap frees in " << kFrames << " steady-state frames";
  if (counts.allocations > 0)
    printFirstAllocation();
  return detected;
}

const CameraIntrinsics kVga = CameraIntrinsics::thesisDefault(640, 480);

// A spool approaching and drifting sideways: the candidates and the hole window change per frame.
std::vector<cv::Mat> drawnApproach(const CameraIntrinsics& camera, cv::Size size)
{
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 6; ++i)
  {
    st::SceneStyle style;
    style.noise_sigma = 2.0;
    style.seed = static_cast<std::uint64_t>(i + 1);
    frames.push_back(st::drawScene(size, {st::spoolAt(camera, 1.0 - 0.08 * i, 0.01 * i - 0.02, 0.06)}, style));
  }
  return frames;
}

// The raw frame a lens with `camera`'s distortion makes of `ideal`.
cv::Mat distort(const cv::Mat& ideal, const CameraIntrinsics& camera)
{
  cv::Mat table;
  spool_vision::undistortionTable(camera, table);
  cv::Mat raw;
  cv::remap(ideal, raw, table, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return raw;
}
}  // namespace

TEST(Allocations, CounterSeesOpenCvLibstdcxxAndCAllocations)
{
  // The counter must see what it claims to, or a zero below proves nothing.
  void* (*volatile c_malloc)(std::size_t) = &malloc;
  const Counts c = count([&] { free(c_malloc(32)); });
  EXPECT_EQ(c.allocations, 1);
  EXPECT_EQ(c.frees, 1);
  const Counts cv_mat = count([] { cv::Mat m(480, 640, CV_8UC3); });
  EXPECT_GE(cv_mat.allocations, 1);
  const Counts string = count([] { std::string s(100, 'x'); });
  EXPECT_GE(string.allocations, 1);
  // OpenCV's own scratch memory (cv::AutoBuffer, filter engines) is C allocation too.
  cv::Mat gray(120, 160, CV_8U, cv::Scalar(0));
  cv::Mat blurred;
  cv::GaussianBlur(gray, blurred, {5, 5}, 1.0);
  const Counts blur = count([&] { cv::GaussianBlur(gray, blurred, {5, 5}, 1.0); });
  EXPECT_GE(blur.allocations, 1);
}

TEST(Allocations, DrawnSpoolStreamAt640x480Bgr8)
{
  SpoolDetector detector;
  EXPECT_EQ(expectSteadyState(detector, drawnApproach(kVga, {640, 480}), PixelFormat::kBgr8), kFrames);
}

TEST(Allocations, RenderedShelfFramesAt640x480Bgr8)
{
  // The renderer's shelf: texture, ribs, a lit or dark bore (the lens search), neighbours.
  const spool_vision::SpoolRenderer renderer(kVga);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 3; ++i)
  {
    spool_vision::CameraPose pose;
    pose.distance = 0.6 + 0.15 * i;
    pose.lateral = 0.01 * i;
    frames.push_back(
        renderer
            .render(spool_vision::randomScene(spool_vision::SceneKind::kSpool, static_cast<std::uint64_t>(i + 3)), pose)
            .image);
  }
  SpoolDetector detector;
  EXPECT_GT(expectSteadyState(detector, frames, PixelFormat::kBgr8), 0);
}

TEST(Allocations, DrawnSpoolStreamAt160x120)
{
  const CameraIntrinsics camera = CameraIntrinsics::thesisDefault(160, 120);
  SpoolDetector detector;
  detector.setCamera(camera);
  EXPECT_GT(expectSteadyState(detector, drawnApproach(camera, {160, 120}), PixelFormat::kBgr8), 0);
}

TEST(Allocations, Mono8Stream)
{
  std::vector<cv::Mat> frames;
  for (const cv::Mat& bgr : drawnApproach(kVga, {640, 480}))
  {
    cv::Mat gray;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    frames.push_back(gray);
  }
  SpoolDetector detector;
  EXPECT_EQ(expectSteadyState(detector, frames, PixelFormat::kMono8), kFrames);
}

TEST(Allocations, FramesWithoutASpool)
{
  // An empty shelf slot (boards, wall, clutter edges) and plain noise: no candidate, or only
  // candidates that fail the hole rule.
  const spool_vision::SpoolRenderer renderer(kVga);
  std::vector<cv::Mat> frames = {
      renderer.render(spool_vision::randomScene(spool_vision::SceneKind::kEmptySlot, 11), {}).image,
      renderer.render(spool_vision::randomScene(spool_vision::SceneKind::kPlate, 12), {}).image};
  cv::Mat noise(480, 640, CV_8UC3);
  cv::randu(noise, cv::Scalar::all(0), cv::Scalar::all(255));
  frames.push_back(noise);
  SpoolDetector detector;
  expectSteadyState(detector, frames, PixelFormat::kBgr8);
}

TEST(Allocations, CameraWithLensDistortion)
{
  CameraIntrinsics camera = kVga;
  camera.cx = 326.0;
  camera.cy = 236.0;
  camera.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0};
  CameraIntrinsics ideal = camera;
  ideal.distortion.clear();
  std::vector<cv::Mat> frames;
  for (const cv::Mat& frame : drawnApproach(ideal, {640, 480}))
    frames.push_back(distort(frame, camera));
  SpoolDetector detector;
  detector.setCamera(camera);
  EXPECT_EQ(expectSteadyState(detector, frames, PixelFormat::kBgr8), kFrames);
  EXPECT_FALSE(detector.usingFallbackCamera());
}

TEST(Allocations, SteadyStateHoldsInTwentyFreshProcesses)
{
  // What once failed one process in five (OpenCV's worker threads starting inside detect() and
  // allocating their thread-local data) depends on the process's thread pool, so the colour
  // streams are checked again in fresh processes: a one-in-five failure cannot pass twenty.
  char self[4096] = {};
  const ssize_t length = readlink("/proc/self/exe", self, sizeof(self) - 1);
  ASSERT_GT(length, 0);
  const std::string command = std::string(self) +
                              " --gtest_filter=Allocations.DrawnSpoolStreamAt640x480Bgr8:Allocations.Mono8Stream:"
                              "Allocations.DrawnSpoolStreamAt160x120 >/dev/null 2>&1";
  int failed = 0;
  for (int run = 0; run < 20; ++run)
    failed += std::system(command.c_str()) == 0 ? 0 : 1;
  EXPECT_EQ(failed, 0) << "of 20 fresh processes (rerun: " << command << ")";
}
