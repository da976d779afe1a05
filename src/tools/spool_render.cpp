// spool_render: writes a labelled set of synthetic spool frames (PNG + ground-truth JSON) and
// the camera's calibration YAML to a folder.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_args.h"
#include "spool_vision/eval/evaluation.h"
#include "spool_vision/io/config_io.h"
#include "spool_vision/render/spool_renderer.h"

namespace sv = spool_vision;

namespace
{
const char* const kUsage =
    "usage: spool_render --out DIR --width W --height H [--focal F] [--distortion D] [--count N]\n"
    "                    [--seed S] [--set main|approach|negatives|hard|distorted|approach_hard|oblique|packed|\n"
    "                          packed_oblique]\n"
    "  --focal F   focal length in px (default: the thesis camera, 200 px at 120 rows)\n"
    "  --distortion D  lens distortion, OpenCV/ROS order: k1,k2,p1,p2[,k3] (plumb_bob) or\n"
    "              k1,k2,p1,p2,k3,k4,k5,k6 (rational_polynomial); default: the set's lens\n"
    "              (none; distorted: -0.2,0.05,0.001,-0.0005,0)\n"
    "  --count N   frames (default: main, hard, distorted, oblique, packed and packed_oblique 500,\n"
    "              approach and approach_hard 40, negatives 100)\n"
    "  --seed S    the set is a function of the seed (default 1)\n"
    "  --set       main: spools at 50-110 cm and +-20 deg bearing plus ~15% negatives;\n"
    "              approach: one spool from 110 cm to 50 cm, ending aligned;\n"
    "              negatives: empty slots and round objects that are not spools;\n"
    "              hard: main's poses with webcam effects (auto exposure, gain noise, MJPEG,\n"
    "              blur), glossy ribbed faces, dark bores, clutter and the puller rod in view;\n"
    "              distorted: main's frames through a C270-like lens, every third frame near\n"
    "              the end of an approach (48-62 cm, puller within a few mm of the bore axis);\n"
    "              approach_hard: approach's path with hard's webcam, faces and clutter, blur\n"
    "              from driving at 10-30 cm/s; half of the seeds end just off (the puller\n"
    "              turned 0.8-1.3 deg or 2.8-4 mm beside the bore axis: it would touch);\n"
    "              oblique: hard's scenes seen 25-40 deg off the spool axis, bearing +-15 deg;\n"
    "              packed: hard's frames on a packed shelf (1-3 neighbours each side, touching on\n"
    "              half the scenes; a back row seen through the gaps on seven in ten);\n"
    "              packed_oblique: oblique's scenes on packed's shelf (touching neighbours seen\n"
    "              25-40 deg off their axes overlap the target's flanges)\n"
    "Writes DIR/frame_%05d.png, DIR/frame_%05d.json and DIR/camera_info.yaml.\n";

struct Options
{
  std::string out;
  int width = 0;
  int height = 0;
  double focal = 0.0;
  std::optional<std::vector<double>> distortion;
  int count = 0;
  std::uint64_t seed = 1;
  std::string set = "main";
  sv::FrameSet frame_set = sv::FrameSet::kMain;
};

// "k1,k2,p1,p2[,k3]" or eight coefficients -> the distortion vector.
std::vector<double> parseDistortion(const std::string& text)
{
  std::vector<double> d;
  std::stringstream list(text);
  std::string item;
  while (std::getline(list, item, ','))
  {
    const std::optional<double> value = sv::cli::parseNumber(item);
    if (!value)
      throw sv::cli::UsageError("--distortion: '" + item + "' is not a number");
    d.push_back(*value);
  }
  if (d.size() != 4 && d.size() != 5 && d.size() != 8)
    throw sv::cli::UsageError("--distortion: expected 4, 5 (plumb_bob) or 8 (rational_polynomial) numbers, got " +
                              std::to_string(d.size()));
  return d;
}

Options parseOptions(int argc, char** argv)
{
  using sv::cli::UsageError;
  const sv::cli::CommandLine line(
      argc, argv, {"--out", "--width", "--height", "--focal", "--distortion", "--count", "--seed", "--set"}, kUsage);
  Options o;
  o.out = line.text("--out");
  o.width = line.positiveInteger("--width", 8192, 0);
  o.height = line.positiveInteger("--height", 8192, 0);
  o.focal = line.positiveNumber("--focal", 0.0);
  if (!line.text("--distortion").empty())
    o.distortion = parseDistortion(line.text("--distortion"));
  o.count = line.positiveInteger("--count", 1000000, 0);
  o.seed = line.seed("--seed", o.seed);
  o.set = line.text("--set", o.set);
  const std::optional<sv::FrameSet> set = sv::frameSetNamed(o.set);
  if (!set)
    throw UsageError(
        "--set: expected main, approach, negatives, hard, distorted, approach_hard, oblique, packed or packed_oblique, "
        "got '" +
        o.set + "'");
  o.frame_set = *set;
  if (o.out.empty())
    throw UsageError("--out is required");
  if (o.width == 0 || o.height == 0)
    throw UsageError("--width and --height are required");
  if (o.width < 32 || o.height < 32)
    throw UsageError("--width/--height: at least 32 px");
  if (o.count == 0)
    o.count = o.frame_set == sv::FrameSet::kApproach || o.frame_set == sv::FrameSet::kApproachHard
                  ? 40
                  : (o.frame_set == sv::FrameSet::kNegatives ? 100 : 500);
  return o;
}

int run(int argc, char** argv)
{
  namespace fs = std::filesystem;
  const Options o = parseOptions(argc, argv);
  fs::create_directories(o.out);
  sv::CameraIntrinsics camera = sv::setCamera(o.frame_set, cv::Size(o.width, o.height), o.focal);
  if (o.distortion)
    camera.distortion = *o.distortion;
  sv::saveCameraInfoYaml((fs::path(o.out) / "camera_info.yaml").string(), camera, "spool_render");
  const sv::SpoolRenderer renderer(camera);
  for (int i = 0; i < o.count; ++i)
  {
    sv::SceneParams scene;
    sv::CameraPose pose;
    sv::setFrame(o.frame_set, o.seed, i, o.count, scene, pose);
    const sv::RenderedFrame frame = renderer.render(scene, pose);

    char name[32];
    std::snprintf(name, sizeof(name), "frame_%05d", i);
    const fs::path png = fs::path(o.out) / (std::string(name) + ".png");
    if (!cv::imwrite(png.string(), frame.image))
      throw std::runtime_error("cannot write " + png.string());
    nlohmann::ordered_json line = {
        {"image", std::string(name) + ".png"}, {"index", i}, {"set", o.set}, {"seed", scene.seed}};
    line.update(sv::groundTruthJson(frame.truth));
    std::ofstream json(fs::path(o.out) / (std::string(name) + ".json"));
    json << line.dump() << "\n";
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
