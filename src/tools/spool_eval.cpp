// spool_eval: renders labelled sets, runs the detector (and its thesis variants) on them and
// writes the evaluation report (DESIGN.md §7 bars, thesis chapter 4 analyses) with PNG charts.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <set>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "cli_args.h"
#include "spool_vision/config_io.h"
#include "spool_vision/evaluation.h"

namespace sv = spool_vision;
using sv::cli::UsageError;

namespace
{
const char* const kUsage =
    "usage: spool_eval --out DIR [--count N] [--negatives N] [--repeats N] [--seed S] [--quick]\n"
    "                  [--config-dir DIR] [--require-bars]\n"
    "  --out DIR         report folder: report.md and PNG charts (created)\n"
    "  --count N         main-set frames per setup (default 400, --quick 60)\n"
    "  --negatives N     negatives-set frames per setup (default half of --count)\n"
    "  --repeats N       scenes per controlled pose (default 3, --quick 1)\n"
    "  --seed S          the sets are a function of the seed (default 1)\n"
    "  --quick           a small sample for a first look\n"
    "  --config-dir DIR  folder with seed.yaml and default.yaml (default: the package's config/)\n"
    "  --require-bars    exit 3 when a 640x480 bar fails\n"
    "Setups: seed.yaml at 160x120 (the thesis) and default.yaml at 640x480. The headline table goes\n"
    "to stdout, progress to stderr. Exit: 0 ran, 1 failed, 2 bad option or config, 3 bar failed.\n";

struct Options
{
  std::string out;
  int count = 0;
  int negatives = 0;
  int repeats = 0;
  std::uint64_t seed = 1;
  bool quick = false;
  std::string config_dir = SPOOL_VISION_SOURCE_DIR "/config";
  bool require_bars = false;
};

Options parseOptions(int argc, char** argv)
{
  const sv::cli::CommandLine line(argc, argv,
                                  {"--out", "--count", "--negatives", "--repeats", "--seed", "--config-dir"}, kUsage,
                                  false, {"--quick", "--require-bars"});
  Options o;
  o.out = line.text("--out");
  o.quick = line.has("--quick");
  o.require_bars = line.has("--require-bars");
  o.count = line.positiveInteger("--count", 100000, 0);
  o.negatives = line.positiveInteger("--negatives", 100000, 0);
  o.repeats = line.positiveInteger("--repeats", 100, 0);
  o.seed = line.seed("--seed", o.seed);
  o.config_dir = line.text("--config-dir", o.config_dir);
  if (o.out.empty())
    throw UsageError("--out is required");
  if (o.count == 0)
    o.count = o.quick ? 60 : 400;
  if (o.negatives == 0)
    o.negatives = std::max(1, o.count / 2);
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

int run(int argc, char** argv)
{
  const Options options = parseOptions(argc, argv);
  sv::EvaluationConfig config;
  try
  {
    config.setups = {
        {"seed.yaml @ 160x120", {160, 120}, loadConfig(options.config_dir, "seed.yaml"), sv::QualityBars::thesisSize()},
        {"default.yaml @ 640x480", {640, 480}, loadConfig(options.config_dir, "default.yaml"), sv::QualityBars::vga()}};
  }
  catch (const std::exception& e)
  {
    // A config file that is missing or refused (a ParamError names the key).
    throw UsageError(e.what(), false);
  }
  const size_t vga_setup = 1;
  config.seed = options.seed;
  config.main_count = options.count;
  config.negative_count = options.negatives;
  config.pose_repeats = options.repeats;
  std::filesystem::create_directories(options.out);  // fail before the run, not after it
  cv::setNumThreads(1);                              // the speed bars are per core
  const auto start = std::chrono::steady_clock::now();
  const sv::EvaluationResult result = sv::runEvaluation(config, showProgress);
  sv::writeReport(result, options.out);
  std::cout << sv::headlineTable(result);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << "spool_eval: done in " << static_cast<int>(seconds)
            << " s; report: " << (std::filesystem::path(options.out) / "report.md").string() << "\n";
  return options.require_bars && !sv::barsPass(result, vga_setup) ? 3 : 0;
}
}  // namespace

int main(int argc, char** argv)
{
  return sv::cli::runTool("spool_eval", kUsage, [&] { return run(argc, argv); });
}
