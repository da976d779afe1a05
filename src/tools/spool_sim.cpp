// spool_sim: closed-loop insertion trials. A simulated forklift renders what its camera sees,
// the detector and tracker read it, the reference controller drives on what the node would
// publish, and the renderer's geometry judges the push (sim/closed_loop.h).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_args.h"
#include "python_script.h"
#include "spool_vision/io/config_io.h"
#include "spool_vision/sim/closed_loop.h"

namespace sv = spool_vision;

namespace
{
const char* const kUsage =
    "usage: spool_sim [--trials N] [--seed S] [--width W] [--height H] [--rate HZ] [--max-steps N]\n"
    "                 [--config YAML] [--pictures DIR] [--frames DIR] [--jobs J] [--oracle]\n"
    "                 [--no-odometry] [--target-hint M]\n"
    "  --trials N     trials, seeds S .. S+N-1 (default 10)\n"
    "  --seed S       first trial's seed (default 1)\n"
    "  --width W --height H  camera mode (default 640x480)\n"
    "  --rate HZ      frames and control periods per second (default 10)\n"
    "  --max-steps N  control periods before a timeout (default 300)\n"
    "  --config YAML  detector parameters (default: config/default.yaml's values); given again,\n"
    "                 each file's keys override the ones before (e.g. config/default.yaml, then\n"
    "                 config/forklift_mount.yaml: what the robot's camera mount tells the tracker)\n"
    "  --pictures DIR for each trial not inserted: its first, worst and last frame with the\n"
    "                 overlay; every trial's trajectory in DIR/trials.jsonl, drawn from above in\n"
    "                 DIR/trajectories.png (scripts/plot_sim.py)\n"
    "  --frames DIR   every frame the camera saw, as spool_render writes a set:\n"
    "                 DIR/<seed>/frame_%05d.png with its truth in frame_%05d.json, and\n"
    "                 DIR/<seed>/camera_info.yaml (replay with spool_detect --track\n"
    "                 --camera-info DIR/<seed>/camera_info.yaml --rate HZ DIR/<seed>)\n"
    "  --jobs J       trials run at once (default 2)\n"
    "  --oracle       drive on the renderer's truth instead of the detector (proves the\n"
    "                 simulation and the controller: must insert every time)\n"
    "  --no-odometry  do not give the tracker the camera's motion from the robot's odometry\n"
    "                 (the node without ~odom_frame)\n"
    "  --target-hint M  tell the tracker where the slot is (its navigation's guess, up to 5 cm\n"
    "                 off), within M m (e.g. 0.15): only a spool there is ever followed\n"
    "                 (default: none, the detector's own target rule)\n"
    "Prints one JSON line per trial, then a summary line {\"summary\": ...}. Exit 0 when every\n"
    "trial ran (whatever its outcome), 1 on an error, 2 on a bad command line.\n";

double finiteOr(double value, double fallback)
{
  return std::isfinite(value) ? value : fallback;
}

nlohmann::ordered_json trialJson(const sv::TrialResult& r)
{
  nlohmann::ordered_json j;
  j["seed"] = r.seed;
  j["outcome"] = sv::toString(r.outcome);
  j["start"] = {{"depth", r.start.robot.depth},
                {"lateral", r.start.robot.x},
                {"heading_deg", r.start.robot.heading * 180.0 / M_PI},
                {"lift_error", r.start.robot.lift - sv::GeometryParams{}.puller_offset_y}};
  j["steps"] = r.steps;
  j["time_to_insert"] = std::isfinite(r.time_to_insert) ? nlohmann::json(r.time_to_insert) : nlohmann::json();
  j["front_miss_mm"] = std::isfinite(r.front_miss) ? nlohmann::json(1000.0 * r.front_miss) : nlohmann::json();
  j["back_miss_mm"] = std::isfinite(r.back_miss) ? nlohmann::json(1000.0 * r.back_miss) : nlohmann::json();
  j["tolerance_mm"] = 1000.0 * r.tolerance;
  j["retries"] = r.retries;
  j["frames"] = {{"detected", r.frames_detected}, {"coasting", r.frames_coasting}, {"refused", r.frames_refused}};
  j["worst_depth_error"] = r.worst_depth_error;
  const std::size_t truly = static_cast<std::size_t>(
      std::count_if(r.trajectory.begin(), r.trajectory.end(), [](const sv::TrialStep& s) { return s.truly_aligned; }));
  j["truly_aligned_frames"] = truly;
  return j;
}

nlohmann::ordered_json trajectoryJson(const sv::TrialResult& r)
{
  nlohmann::ordered_json path = nlohmann::ordered_json::array();
  for (const sv::TrialStep& s : r.trajectory)
    path.push_back({{"t", s.time},
                    {"x", s.robot.x},
                    {"depth", s.robot.depth},
                    {"heading_deg", s.robot.heading * 180.0 / M_PI},
                    {"lift", s.robot.lift},
                    {"phase", sv::toString(s.phase)},
                    {"detected", s.detected},
                    {"aligned", s.aligned},
                    {"truly_aligned", s.truly_aligned},
                    {"true_depth", s.true_depth},
                    {"published_depth", finiteOr(s.published_depth, -1.0)},
                    {"track_miss_mm",
                     {1000.0 * finiteOr(s.track_front_miss, -0.001), 1000.0 * finiteOr(s.track_back_miss, -0.001),
                      1000.0 * finiteOr(s.track_miss_sigma, -0.001)}},
                    {"true_miss_mm", {1000.0 * s.true_front_miss, 1000.0 * s.true_back_miss}}});
  return path;
}

/// One frame of --frames, laid out as spool_render writes a set.
void writeFrame(const std::filesystem::path& dir, int step, const sv::RenderedFrame& frame,
                const sv::CameraIntrinsics& camera)
{
  if (step == 0)
  {
    std::filesystem::create_directories(dir);
    sv::saveCameraInfoYaml((dir / "camera_info.yaml").string(), camera, "spool_sim");
  }
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%05d", step);
  if (!cv::imwrite((dir / (std::string(name) + ".png")).string(), frame.image))
    throw std::runtime_error("--frames: cannot write " + (dir / name).string() + ".png");
  std::ofstream json(dir / (std::string(name) + ".json"));
  json << sv::groundTruthJson(frame.truth).dump() << "\n";
  if (!json)
    throw std::runtime_error("--frames: cannot write " + (dir / name).string() + ".json");
}

double median(std::vector<double> v)
{
  if (v.empty())
    return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int run(int argc, char** argv)
{
  const sv::cli::CommandLine line(argc, argv,
                                  {"--trials", "--seed", "--width", "--height", "--rate", "--max-steps", "--config",
                                   "--pictures", "--frames", "--jobs", "--target-hint"},
                                  kUsage, false, {"--oracle", "--no-odometry"});
  sv::TrialConfig base;
  const int trials = line.positiveInteger("--trials", 100000, 10);
  const std::uint64_t first_seed = line.seed("--seed", 1);
  base.size = {line.positiveInteger("--width", 8192, 640), line.positiveInteger("--height", 8192, 480)};
  if (base.size.width < 64 || base.size.height < 48)
    throw sv::cli::UsageError("--width/--height: the camera mode must be at least 64x48, got " +
                              std::to_string(base.size.width) + "x" + std::to_string(base.size.height));
  base.rate = line.positiveNumber("--rate", 10.0);
  base.max_steps = line.positiveInteger("--max-steps", 100000, 300);
  base.oracle = line.has("--oracle");
  base.odometry_motion = !line.has("--no-odometry");
  base.target_hint_radius = line.text("--target-hint").empty() ? 0.0 : line.positiveNumber("--target-hint", 0.0);
  for (const std::string& config : line.every("--config"))
    sv::loadParamsYaml(config, base.detector);
  const std::string pictures = line.text("--pictures");
  base.keep_pictures = !pictures.empty();
  if (base.keep_pictures)
    std::filesystem::create_directories(pictures);
  const std::string frames = line.text("--frames");
  const int jobs = line.positiveInteger("--jobs", 64, 2);

  std::vector<sv::TrialResult> results(static_cast<std::size_t>(trials));
  std::atomic<int> next{0};
  std::mutex out;
  std::exception_ptr failure;
  auto worker = [&]
  {
    for (int i = next++; i < trials; i = next++)
    {
      try
      {
        sv::TrialConfig config = base;
        config.seed = first_seed + static_cast<std::uint64_t>(i);
        if (!frames.empty())
          config.on_frame = [dir = std::filesystem::path(frames) / std::to_string(config.seed)](
                                int step, const sv::RenderedFrame& frame, const sv::CameraIntrinsics& camera)
          { writeFrame(dir, step, frame, camera); };
        sv::TrialResult r = sv::runTrial(config);
        const std::lock_guard<std::mutex> lock(out);
        std::cout << trialJson(r).dump() << std::endl;
        if (base.keep_pictures && r.outcome != sv::TrialOutcome::kInserted)
        {
          const std::string stem = pictures + "/trial_" + std::to_string(r.seed) + "_";
          cv::imwrite(stem + "first.png", r.first_frame);
          cv::imwrite(stem + "worst.png", r.worst_frame);
          cv::imwrite(stem + "last.png", r.last_frame);
        }
        r.first_frame.release();
        r.worst_frame.release();
        r.last_frame.release();
        results[static_cast<std::size_t>(i)] = std::move(r);
      }
      catch (...)
      {
        const std::lock_guard<std::mutex> lock(out);
        failure = std::current_exception();
        next = trials;
      }
    }
  };
  std::vector<std::thread> threads;
  for (int j = 0; j < std::min(jobs, trials); ++j)
    threads.emplace_back(worker);
  for (std::thread& t : threads)
    t.join();
  if (failure)
    std::rethrow_exception(failure);

  std::map<std::string, int> outcomes;
  for (const char* name : {"inserted", "collision", "timeout", "lost", "wrong_spool"})
    outcomes[name] = 0;
  std::vector<double> times;
  double worst_miss = 0.0;
  for (const sv::TrialResult& r : results)
  {
    ++outcomes[sv::toString(r.outcome)];
    if (r.outcome == sv::TrialOutcome::kInserted)
    {
      times.push_back(r.time_to_insert);
      worst_miss = std::max({worst_miss, r.front_miss, r.back_miss});
    }
  }
  if (base.keep_pictures)
  {
    std::ofstream file(pictures + "/trials.jsonl");
    for (const sv::TrialResult& r : results)
    {
      nlohmann::ordered_json j = trialJson(r);
      j["trajectory"] = trajectoryJson(r);
      file << j.dump() << "\n";
    }
    file.close();
    sv::cli::runPackageScript("plot_sim.py", {pictures + "/trials.jsonl"});
  }
  nlohmann::ordered_json summary;
  summary["trials"] = trials;
  summary["size"] = std::to_string(base.size.width) + "x" + std::to_string(base.size.height);
  summary["controller"] = base.oracle ? "oracle" : "vision";
  summary["config"] = line.every("--config");
  summary["odometry_motion"] = base.odometry_motion;
  summary["target_hint_radius"] = base.target_hint_radius;
  summary["outcomes"] = outcomes;
  summary["inserted_share"] = static_cast<double>(outcomes["inserted"]) / trials;
  summary["median_time_to_insert"] = times.empty() ? nlohmann::json() : nlohmann::json(median(times));
  summary["worst_inserted_miss_mm"] = 1000.0 * worst_miss;
  std::cout << nlohmann::ordered_json{{"summary", summary}}.dump() << std::endl;
  return 0;
}
}  // namespace

int main(int argc, char** argv)
{
  return sv::cli::runTool("spool_sim", kUsage, [&] { return run(argc, argv); });
}
