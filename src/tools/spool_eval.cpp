// spool_eval: renders labelled sets, runs the detector (and its thesis variants) on them and
// writes the evaluation report (DESIGN.md §7 bars, thesis chapter 4 analyses) with its charts,
// drawn by scripts/plot_charts.py (matplotlib) from the charts.json the report writes.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/core.hpp>

#include "cli_args.h"
#include "python_script.h"
#include "spool_vision/eval/evaluation.h"
#include "spool_vision/io/config_io.h"

namespace sv = spool_vision;
using sv::cli::UsageError;

namespace
{
const char* const kUsage =
    "usage: spool_eval --out DIR [--count N] [--negatives N] [--hard N] [--distorted N]\n"
    "                  [--oblique N] [--packed N] [--packed-oblique N] [--sizes WxH,...] [--repeats N] [--seed S]\n"
    "                  [--quick] [--config-dir DIR] [--approaches N] [--require-bars] [--no-charts]\n"
    "  --out DIR         report folder: report.md, charts.json and the PNG charts (created)\n"
    "  --count N         main-set frames per setup (default 400, --quick 60)\n"
    "  --negatives N     negatives-set frames per setup (default half of --count)\n"
    "  --hard N          hard-set frames per setup (default half of --count)\n"
    "  --distorted N     distorted-set frames per setup (default --count)\n"
    "  --oblique N       oblique-set frames per setup (default half of --count)\n"
    "  --packed N        packed-set frames per setup (default half of --count)\n"
    "  --packed-oblique N  packed_oblique-set frames per setup (default half of --count)\n"
    "  --sizes LIST      default.yaml's frame sizes (default 160x120,320x240,640x480; 1280x720 is\n"
    "                    slow). Sizes other than 160x120 and 640x480 get half the counts, above\n"
    "                    640x480 a quarter\n"
    "  --repeats N       scenes per controlled pose (default 3, --quick 1)\n"
    "  --approaches N    approach_hard sequences per size followed by the tracker with\n"
    "                    default.yaml (40 frames at 10 Hz each; default 4, --quick 2; 0 = none)\n"
    "  --seed S          the sets are a function of the seed (default 1)\n"
    "  --quick           a small sample for a first look\n"
    "  --config-dir DIR  folder with seed.yaml and default.yaml (default: the package's config/)\n"
    "  --require-bars    exit 3 when a default.yaml bar fails at any size\n"
    "  --no-charts       write charts.json but draw no PNG (scripts/plot_charts.py draws them later)\n"
    "Setups: seed.yaml at 160x120 (the thesis) and default.yaml at each size, each scored on the\n"
    "main + negatives sets, on the hard set, on the distorted set (a C270-like lens) and on the\n"
    "oblique set (the hard set's scenes 25-40 deg off the spool axis), on the packed set (the\n"
    "hard set's frames on a packed shelf: touching neighbours, a back row) and on the\n"
    "packed_oblique set (the oblique set's scenes on that shelf). The headline\n"
    "and pose tables go to stdout, progress and the frame counts to stderr. Exit: 0 ran, 1 failed,\n"
    "2 bad option or config, 3 bar failed.\n";

struct Options
{
  std::string out;
  sv::FrameCounts counts;  ///< at 160x120 and 640x480 (countsAt() scales the other sizes)
  std::vector<cv::Size> sizes;
  int repeats = 0;
  int approaches = 0;
  std::uint64_t seed = 1;
  bool quick = false;
  std::string config_dir = SPOOL_VISION_SOURCE_DIR "/config";
  bool require_bars = false;
  bool charts = true;
};

// "160x120,640x480" -> sizes, in order, each once.
std::vector<cv::Size> parseSizes(const std::string& text)
{
  std::vector<cv::Size> sizes;
  std::stringstream list(text);
  std::string item;
  while (std::getline(list, item, ','))
  {
    int width = 0;
    int height = 0;
    char x = 0;
    char rest = 0;
    if (std::sscanf(item.c_str(), "%d%c%d%c", &width, &x, &height, &rest) != 3 || x != 'x' || width < 32 ||
        height < 32 || width > 4096 || height > 4096)
      throw UsageError("--sizes: '" + item + "' is not WIDTHxHEIGHT (32-4096 each)");
    if (std::find(sizes.begin(), sizes.end(), cv::Size(width, height)) == sizes.end())
      sizes.emplace_back(width, height);
  }
  if (sizes.empty())
    throw UsageError("--sizes: no size given");
  return sizes;
}

Options parseOptions(int argc, char** argv)
{
  const sv::cli::CommandLine line(
      argc, argv,
      {"--out", "--count", "--negatives", "--hard", "--distorted", "--oblique", "--packed", "--packed-oblique",
       "--sizes", "--repeats", "--seed", "--config-dir", "--approaches"},
      kUsage, false, {"--quick", "--require-bars", "--no-charts"});
  Options o;
  o.out = line.text("--out");
  o.quick = line.has("--quick");
  o.require_bars = line.has("--require-bars");
  o.charts = !line.has("--no-charts");
  // The set sizes not given follow --count (main): half as many negatives and hard frames.
  const int main_frames = line.positiveInteger("--count", 100000, o.quick ? 60 : 400);
  o.counts = {main_frames,
              line.positiveInteger("--negatives", 100000, std::max(1, main_frames / 2)),
              line.positiveInteger("--hard", 100000, std::max(1, main_frames / 2)),
              line.positiveInteger("--distorted", 100000, main_frames),
              line.positiveInteger("--oblique", 100000, std::max(1, main_frames / 2)),
              line.positiveInteger("--packed", 100000, std::max(1, main_frames / 2)),
              line.positiveInteger("--packed-oblique", 100000, std::max(1, main_frames / 2))};
  o.sizes = parseSizes(line.text("--sizes", "160x120,320x240,640x480"));
  o.repeats = line.positiveInteger("--repeats", 100, 0);
  o.approaches = line.nonNegativeInteger("--approaches", 1000, o.quick ? 2 : 4);
  o.seed = line.seed("--seed", o.seed);
  o.config_dir = line.text("--config-dir", o.config_dir);
  if (o.out.empty())
    throw UsageError("--out is required");
  if (o.repeats == 0)
    o.repeats = o.quick ? 1 : 3;
  return o;
}

sv::DetectorParams loadConfig(const std::string& dir, const std::string& name)
{
  sv::DetectorParams params;
  sv::loadParamsYaml((std::filesystem::path(dir) / name).string(), params);
  sv::validateParams(params);
  return params;
}

// One line per step, rewritten in place while it runs.
void showProgress(const std::string& what, int done, int total)
{
  if (done % 10 != 0 && done != total)
    return;
  std::cerr << "\rspool_eval: " << what << " " << done << "/" << total << (done == total ? "\n" : "") << std::flush;
}

std::string sizeName(cv::Size size)
{
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

// 160x120 and 640x480 carry most bars and get the full counts; the other sizes get fewer frames
// so that a default run stays within minutes (a 1280x720 frame renders ~3x slower than 640x480).
sv::FrameCounts countsAt(const Options& o, cv::Size size)
{
  const int divisor = size == cv::Size(160, 120) || size == cv::Size(640, 480) ? 1 : size.area() <= 640 * 480 ? 2 : 4;
  const sv::FrameCounts& c = o.counts;
  return {std::max(1, c.main / divisor),          std::max(1, c.negatives / divisor), std::max(1, c.hard / divisor),
          std::max(1, c.distorted / divisor),     std::max(1, c.oblique / divisor),   std::max(1, c.packed / divisor),
          std::max(1, c.packed_oblique / divisor)};
}

// Draws the report's charts: scripts/plot_charts.py (matplotlib) on `charts` (charts.json).
// Throws std::runtime_error when it cannot run or fails (it says why on stderr).
void drawCharts(const std::string& charts)
{
  try
  {
    sv::cli::runPackageScript("plot_charts.py", {charts});
  }
  catch (const std::runtime_error& e)
  {
    throw std::runtime_error(std::string("charts not drawn (report.md and charts.json are written): ") + e.what());
  }
}

int run(int argc, char** argv)
{
  const Options options = parseOptions(argc, argv);
  sv::EvaluationConfig config;
  try
  {
    const sv::DetectorParams seed = loadConfig(options.config_dir, "seed.yaml");
    const sv::DetectorParams tuned = loadConfig(options.config_dir, "default.yaml");
    const cv::Size thesis_size(160, 120);
    config.setups.push_back({"seed.yaml @ 160x120", thesis_size, seed, sv::QualityBars::thesisReproduction(),
                             countsAt(options, thesis_size), true, false});
    for (cv::Size size : options.sizes)
      // The thesis analyses at 640x480 only: they are the slow part and the thesis setup covers 160x120.
      config.setups.push_back({"default.yaml @ " + sizeName(size), size, tuned, sv::QualityBars::forDefault(size),
                               countsAt(options, size), size == cv::Size(640, 480)});
  }
  catch (const std::exception& e)
  {
    // A config file that is missing or refused (a ParamError names the key).
    throw UsageError(e.what(), false);
  }
  config.seed = options.seed;
  config.pose_repeats = options.repeats;
  config.approaches = options.approaches;
  std::cerr
      << "spool_eval: frames per setup (main / negatives / hard / distorted / oblique / packed / packed_oblique):";
  for (const sv::Setup& setup : config.setups)
    std::cerr << " " << setup.name << " " << setup.counts.main << "/" << setup.counts.negatives << "/"
              << setup.counts.hard << "/" << setup.counts.distorted << "/" << setup.counts.oblique << "/"
              << setup.counts.packed << "/" << setup.counts.packed_oblique << ";";
  std::cerr << "\n";
  std::filesystem::create_directories(options.out);  // fail before the run, not after it
  cv::setNumThreads(1);                              // the speed bars are per core
  const auto start = std::chrono::steady_clock::now();
  const sv::EvaluationResult result = sv::runEvaluation(config, showProgress);
  sv::writeReport(result, options.out);
  const std::string charts = (std::filesystem::path(options.out) / "charts.json").string();
  if (options.charts)
    drawCharts(charts);
  else
    std::cerr << "spool_eval: charts not drawn (--no-charts): scripts/plot_charts.py " << charts
              << " draws the PNGs report.md shows\n";
  std::cout << sv::headlineTable(result) << "\n" << sv::poseTable(result) << "\n" << sv::approachTable(result);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << "spool_eval: done in " << static_cast<int>(seconds)
            << " s; report: " << (std::filesystem::path(options.out) / "report.md").string() << "\n";
  bool pass = true;
  for (size_t s = 1; s < config.setups.size(); ++s)  // default.yaml's; seed.yaml is the thesis, reported
    pass = pass && sv::barsPass(result, s);
  return options.require_bars && !pass ? 3 : 0;
}
}  // namespace

int main(int argc, char** argv)
{
  return sv::cli::runTool("spool_eval", kUsage, [&] { return run(argc, argv); });
}
