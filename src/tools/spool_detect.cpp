// spool_detect: runs the detector on images or folders and prints one JSON object per image.
// Contract: ../shared/DESIGN.md §6. Exit 0 = all images processed, 1 = some image failed,
// 2 = bad option or config.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "json_writer.h"
#include "spool_vision/config_io.h"
#include "spool_vision/spool_detector.h"

namespace fs = std::filesystem;
using spool_vision::JsonObject;

namespace
{
const char* const kUsage =
    "usage: spool_detect [--config FILE] [--camera-info FILE] [--mode mcht|cht] PATH...\n"
    "  PATH       an image (png, jpg, bmp) or a folder of images\n"
    "  --config   parameter YAML (default: built-in defaults = config/default.yaml)\n"
    "  --camera-info  ROS camera-calibration YAML; without it the thesis camera is used\n"
    "  --mode     mcht (concentric constraint, default) or cht (plain CHT, for comparison)\n"
    "Prints one JSON object per image on stdout. Exit: 0 ok, 1 an image failed, 2 bad option/config.\n";

bool isImage(const fs::path& p)
{
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp";
}

std::string circleJson(bool found, const spool_vision::Circle& c)
{
  if (!found)
    return "null";
  return JsonObject().add("x", c.x, 2).add("y", c.y, 2).add("r", c.r, 2).str();
}

bool formatOf(const cv::Mat& image, spool_vision::PixelFormat& format)
{
  using spool_vision::PixelFormat;
  switch (image.type())
  {
    case CV_8UC1:
      format = PixelFormat::kMono8;
      return true;
    case CV_16UC1:
      format = PixelFormat::kMono16;
      return true;
    case CV_8UC3:
      format = PixelFormat::kBgr8;
      return true;
    case CV_8UC4:
      format = PixelFormat::kBgra8;
      return true;
    default:
      return false;
  }
}

struct Options
{
  std::string config;
  std::string camera_info;
  std::string mode;
  std::vector<std::string> paths;
};

// Returns false (after printing why) on a bad command line.
bool parse(int argc, char** argv, Options& o)
{
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto value = [&](std::string& out) {
      if (i + 1 >= argc)
      {
        std::cerr << "spool_detect: " << a << " needs a value\n" << kUsage;
        return false;
      }
      out = argv[++i];
      return true;
    };
    if (a == "--help" || a == "-h")
    {
      std::cout << kUsage;
      std::exit(0);
    }
    else if (a == "--config")
    {
      if (!value(o.config))
        return false;
    }
    else if (a == "--camera-info")
    {
      if (!value(o.camera_info))
        return false;
    }
    else if (a == "--mode")
    {
      if (!value(o.mode))
        return false;
    }
    else if (a.size() > 1 && a[0] == '-')
    {
      std::cerr << "spool_detect: unknown option '" << a << "'\n" << kUsage;
      return false;
    }
    else
    {
      o.paths.push_back(a);
    }
  }
  if (o.paths.empty())
  {
    std::cerr << "spool_detect: no PATH given\n" << kUsage;
    return false;
  }
  return true;
}

// Expands folders into their images (sorted); plain paths stay as given, even if missing, so
// that they produce an error line in order.
std::vector<std::string> expand(const std::vector<std::string>& paths)
{
  std::vector<std::string> files;
  for (const auto& p : paths)
  {
    std::error_code ec;
    if (fs::is_directory(p, ec))
    {
      std::vector<std::string> inside;
      for (const auto& entry : fs::directory_iterator(p, ec))
        if (entry.is_regular_file() && isImage(entry.path()))
          inside.push_back(entry.path().string());
      std::sort(inside.begin(), inside.end());
      files.insert(files.end(), inside.begin(), inside.end());
    }
    else
    {
      files.push_back(p);
    }
  }
  return files;
}
}  // namespace

int main(int argc, char** argv)
{
  Options options;
  if (!parse(argc, argv, options))
    return 2;

  spool_vision::DetectorParams params;
  std::optional<spool_vision::CameraIntrinsics> camera;
  try
  {
    if (!options.config.empty())
      spool_vision::loadParamsYaml(options.config, params);
    if (!options.mode.empty())
      spool_vision::setParam(params, "mode", options.mode);
    if (!options.camera_info.empty())
      camera = spool_vision::loadCameraInfoYaml(options.camera_info);
  }
  catch (const std::exception& e)
  {
    std::cerr << "spool_detect: " << e.what() << "\n";
    return 2;
  }

  spool_vision::SpoolDetector detector(params);
  if (camera)
    detector.setCamera(*camera);

  bool any_failed = false;
  bool fallback_said = false;
  for (const auto& path : expand(options.paths))
  {
    JsonObject out;
    out.add("image", path);
    const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
    spool_vision::PixelFormat format;
    if (image.empty() || !formatOf(image, format))
    {
      std::cout << out.add("error", image.empty() ? "cannot read image" : "unsupported pixel type " +
                                                                             cv::typeToString(image.type()))
                       .str()
                << std::endl;
      any_failed = true;
      continue;
    }
    try
    {
      const spool_vision::SpoolDetection d = detector.detect(image, format);
      if (detector.usingFallbackCamera() && !fallback_said)
      {
        std::cerr << "spool_detect: " << (camera ? "camera info does not match the image size; " : "no camera info; ")
                  << "using the thesis camera (f = " << params.geometry.fallback_focal_length
                  << " px at 120 rows, scaled)\n";
        fallback_said = true;
      }
      out.add("width", image.cols)
          .add("height", image.rows)
          .add("detected", d.detected)
          .add("hole_detected", d.hole_detected)
          .add("distance", d.distance)
          .add("yaw", d.yaw, 5)
          .add("overlapped", d.overlapped)
          .add("aligned", d.aligned)
          .add("lateral_offset", d.lateral_offset, 5)
          .addRaw("flange", circleJson(d.detected, d.flange))
          .addRaw("hole", circleJson(d.hole_detected, d.hole))
          .addRaw("reference", JsonObject().add("x", d.reference.x, 2).add("y", d.reference.y, 2).str())
          .add("time_ms", d.time_ms, 3);
    }
    catch (const std::exception& e)
    {
      out.add("error", e.what());
      any_failed = true;
    }
    std::cout << out.str() << std::endl;
  }
  return any_failed ? 1 : 0;
}
