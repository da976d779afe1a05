// Per-frame time of SpoolDetector beside cv::HoughCircles doing the same two-range job (flange
// radii and hole radii) on the same frames, at 160x120 and 640x480. cv::HoughCircles appears
// here only as the comparison. Prints the speed ratio after the table.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "spool_vision/evaluation.h"
#include "spool_vision/spool_detector.h"
#include "synthetic.h"

using spool_vision::CameraIntrinsics;
using spool_vision::test::drawScene;
using spool_vision::test::SceneStyle;
using spool_vision::test::spoolAt;

namespace
{
// A fixed set of noisy frames over the working range (distance, lateral offset, neighbours).
std::vector<cv::Mat> frames(int width, int height)
{
  const auto k = CameraIntrinsics::thesisDefault(width, height);
  std::vector<cv::Mat> out;
  int seed = 1;
  for (double depth : {0.55, 0.7, 0.85, 1.0, 1.1})
    for (double lateral : {-0.08, 0.0, 0.06})
    {
      SceneStyle style;
      style.noise_sigma = 4.0;
      style.seed = static_cast<std::uint64_t>(seed++);
      out.push_back(drawScene({width, height},
                              {spoolAt(k, depth, lateral - 0.38, 0.06), spoolAt(k, depth, lateral, 0.06),
                               spoolAt(k, depth, lateral + 0.38, 0.06)},
                              style));
    }
  return out;
}

void spoolDetector(benchmark::State& state)
{
  const auto images = frames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  spool_vision::SpoolDetector detector;
  size_t i = 0;
  int detected = 0;
  for (auto _ : state)
  {
    const auto d = detector.detect(images[i++ % images.size()], spool_vision::PixelFormat::kBgr8);
    detected += d.detected ? 1 : 0;
    benchmark::DoNotOptimize(d);
  }
  state.counters["detected"] = benchmark::Counter(detected, benchmark::Counter::kAvgIterations);
}

void houghCircles(benchmark::State& state)
{
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const auto images = frames(width, height);
  // Same radius ranges as the detector searches with its defaults.
  spool_vision::HoughCirclesBaseline baseline(
      spool_vision::searchRadii(spool_vision::DetectorParams(), CameraIntrinsics::thesisDefault(width, height)));
  size_t i = 0;
  int detected = 0;
  for (auto _ : state)
  {
    baseline.detect(images[i++ % images.size()]);
    detected += baseline.flanges().empty() ? 0 : 1;
    benchmark::DoNotOptimize(baseline.holes().data());
  }
  state.counters["detected"] = benchmark::Counter(detected, benchmark::Counter::kAvgIterations);
}

// Records per-benchmark times so main() can print ours / OpenCV's.
class RatioReporter : public benchmark::ConsoleReporter
{
public:
  void ReportRuns(const std::vector<Run>& runs) override
  {
    for (const auto& r : runs)
      if (r.run_type == Run::RT_Iteration)
        ms_[r.benchmark_name()] = r.GetAdjustedRealTime();
    ConsoleReporter::ReportRuns(runs);
  }
  void printRatios() const
  {
    for (const char* size : {"160/120", "640/480"})
    {
      const auto ours = ms_.find(std::string("SpoolDetector/") + size + "/real_time");
      const auto theirs = ms_.find(std::string("HoughCircles/") + size + "/real_time");
      if (ours != ms_.end() && theirs != ms_.end())
        std::printf("%s: SpoolDetector %.3f ms, cv::HoughCircles %.3f ms per frame -> ours is %.1fx faster\n", size,
                    ours->second, theirs->second, theirs->second / ours->second);
    }
  }

private:
  std::map<std::string, double> ms_;
};
}  // namespace

BENCHMARK(spoolDetector)
    ->Name("SpoolDetector")
    ->Args({160, 120})
    ->Args({640, 480})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(houghCircles)
    ->Name("HoughCircles")
    ->Args({160, 120})
    ->Args({640, 480})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

int main(int argc, char** argv)
{
  cv::setNumThreads(1);  // one core, as the bar says
  benchmark::Initialize(&argc, argv);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.printRatios();
  return 0;
}
