// spool_render: writes a labelled set of synthetic spool frames (PNG + ground-truth JSON) and
// the camera's calibration YAML to a folder.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_args.h"
#include "spool_vision/config_io.h"
#include "spool_vision/spool_renderer.h"

namespace sv = spool_vision;

namespace
{
constexpr double kDeg = M_PI / 180.0;

const char* const kUsage =
    "usage: spool_render --out DIR --width W --height H [--focal F] [--count N] [--seed S]\n"
    "                    [--set main|approach|negatives]\n"
    "  --focal F   focal length in px (default: the thesis camera, 200 px at 120 rows)\n"
    "  --count N   frames (default: main 500, approach 40, negatives 100)\n"
    "  --seed S    the set is a function of the seed (default 1)\n"
    "  --set       main: spools at 50-110 cm and +-20 deg bearing plus ~15% negatives;\n"
    "              approach: one spool from 110 cm to 50 cm, ending aligned;\n"
    "              negatives: empty slots and round objects that are not spools\n"
    "Writes DIR/frame_%05d.png, DIR/frame_%05d.json and DIR/camera_info.yaml.\n";

struct Options
{
  std::string out;
  int width = 0;
  int height = 0;
  double focal = 0.0;
  int count = 0;
  std::uint64_t seed = 1;
  std::string set = "main";
};

Options parseOptions(int argc, char** argv)
{
  using sv::cli::UsageError;
  const sv::cli::CommandLine line(argc, argv, {"--out", "--width", "--height", "--focal", "--count", "--seed", "--set"},
                                  kUsage);
  Options o;
  o.out = line.text("--out");
  o.width = line.positiveInteger("--width", 8192, 0);
  o.height = line.positiveInteger("--height", 8192, 0);
  o.focal = line.positiveNumber("--focal", 0.0);
  o.count = line.positiveInteger("--count", 1000000, 0);
  const std::string seed = line.text("--seed", std::to_string(o.seed));
  if (seed.empty() || seed.find_first_not_of("0123456789") != std::string::npos)
    throw UsageError("--seed: expected a non-negative integer, got '" + seed + "'");
  o.seed = std::stoull(seed);
  o.set = line.text("--set", o.set);
  if (o.set != "main" && o.set != "approach" && o.set != "negatives")
    throw UsageError("--set: expected main, approach or negatives, got '" + o.set + "'");
  if (o.out.empty())
    throw UsageError("--out is required");
  if (o.width == 0 || o.height == 0)
    throw UsageError("--width and --height are required");
  if (o.width < 32 || o.height < 32)
    throw UsageError("--width/--height: at least 32 px");
  if (o.count == 0)
    o.count = o.set == "main" ? 500 : (o.set == "approach" ? 40 : 100);
  return o;
}

std::uint64_t frameSeed(std::uint64_t seed, int index)
{
  return seed * 1000003ULL + static_cast<std::uint64_t>(index) * 7919ULL + 17ULL;
}

// The camera looks at the slot from `distance` with the slot centre at `bearing` in the image
// and the robot's heading off by `heading`; the lateral position follows from the three.
sv::CameraPose bearingPose(double distance, double bearing, double heading, double height, double pitch)
{
  sv::CameraPose pose;
  pose.distance = distance;
  pose.height = height;
  pose.yaw = heading;
  pose.pitch = pitch;
  pose.lateral = -std::sqrt(distance * distance - height * height) * std::sin(bearing + heading);
  return pose;
}

sv::SceneKind randomNegative(cv::RNG& rng)
{
  static const sv::SceneKind kinds[] = {sv::SceneKind::kEmptySlot, sv::SceneKind::kPlate, sv::SceneKind::kTapeRoll,
                                        sv::SceneKind::kCan};
  return kinds[rng.uniform(0, 4)];
}

// One frame of the main or negatives set: random scene, random pose over the working range.
void randomFrame(const Options& o, int index, sv::SceneParams& scene, sv::CameraPose& pose)
{
  const std::uint64_t seed = frameSeed(o.seed, index);
  cv::RNG rng(seed);
  sv::SceneKind kind = sv::SceneKind::kSpool;
  if (o.set == "negatives" || rng.uniform(0.0, 1.0) < 0.15)
    kind = randomNegative(rng);
  scene = sv::randomScene(kind, seed);
  pose = bearingPose(rng.uniform(0.5, 1.1), rng.uniform(-20.0, 20.0) * kDeg, rng.uniform(-5.0, 5.0) * kDeg,
                     rng.uniform(0.05, 0.07), rng.uniform(-2.0, 2.0) * kDeg);
}

// One frame of an approach: 110 cm to 50 cm, the lateral and heading errors shrink to zero
// by 80% of the way (about 62 cm), so the last frames inside 60 cm are aligned.
void approachFrame(const Options& o, int index, sv::SceneParams& scene, sv::CameraPose& pose)
{
  const std::uint64_t shelf_seed = ~frameSeed(o.seed, 0);  // the shelf shared by all frames
  cv::RNG rng(shelf_seed);
  scene = sv::randomScene(sv::SceneKind::kSpool, shelf_seed);
  const double lateral0 = (rng.uniform(0, 2) ? 1.0 : -1.0) * rng.uniform(0.05, 0.15);
  const double heading0 = rng.uniform(-3.0, 3.0) * kDeg;
  const double s = o.count > 1 ? static_cast<double>(index) / (o.count - 1) : 1.0;
  const double left = std::pow(std::max(0.0, 1.0 - s / 0.8), 2.0);
  scene.seed = frameSeed(o.seed, index);  // fresh sensor noise per frame, same shelf
  pose.distance = 1.10 - 0.60 * s;
  pose.lateral = lateral0 * left;
  pose.yaw = heading0 * left;
  pose.height = 0.06;
  pose.pitch = 0.0;
}

int run(int argc, char** argv)
{
  namespace fs = std::filesystem;
  const Options o = parseOptions(argc, argv);
  fs::create_directories(o.out);
  sv::CameraIntrinsics camera = sv::CameraIntrinsics::thesisDefault(o.width, o.height);
  if (o.focal > 0.0)
    camera.fx = camera.fy = o.focal;
  sv::saveCameraInfoYaml((fs::path(o.out) / "camera_info.yaml").string(), camera, "spool_render");
  const sv::SpoolRenderer renderer(camera);
  for (int i = 0; i < o.count; ++i)
  {
    sv::SceneParams scene;
    sv::CameraPose pose;
    if (o.set == "approach")
      approachFrame(o, i, scene, pose);
    else
      randomFrame(o, i, scene, pose);
    const sv::RenderedFrame frame = renderer.render(scene, pose);

    char name[32];
    std::snprintf(name, sizeof(name), "frame_%05d", i);
    const fs::path png = fs::path(o.out) / (std::string(name) + ".png");
    if (!cv::imwrite(png.string(), frame.image))
      throw std::runtime_error("cannot write " + png.string());
    std::ofstream json(fs::path(o.out) / (std::string(name) + ".json"));
    json << "{\"image\": \"" << name << ".png\", \"index\": " << i << ", \"set\": \"" << o.set
         << "\", \"seed\": " << scene.seed << ", " << sv::groundTruthToJson(frame.truth).substr(1) << "\n";
    if (!json)
      throw std::runtime_error("cannot write the JSON of " + png.string());
    if ((i + 1) % 50 == 0 || i + 1 == o.count)
      std::cerr << "spool_render: " << (i + 1) << "/" << o.count << " frames\r" << std::flush;
  }
  std::cerr << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  return sv::cli::runTool("spool_render", kUsage, [&] { return run(argc, argv); });
}
