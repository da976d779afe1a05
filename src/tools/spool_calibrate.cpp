// spool_calibrate: fits the focal length (and the thesis' "sensor height") from flange
// diameters observed at tape-measured distances and writes a ROS camera-calibration YAML.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "spool_vision/config_io.h"
#include "spool_vision/focal_calibration.h"
#include "spool_vision/types.h"

namespace sv = spool_vision;

namespace
{
const char* const kUsage =
    "usage: spool_calibrate --csv FILE --width W --height H [--out FILE]\n"
    "                       [--flange-diameter M] [--lens-focal-length M] [--camera-name NAME]\n"
    "  --csv FILE   pairs of measured distance and observed flange diameter: '#' comments, a\n"
    "               header naming a distance column (suffix _m, _cm or _mm) and a px column\n"
    "               (e.g. measured_distance_cm,object_height_px)\n"
    "  --width W --height H   the image size the diameters were measured in\n"
    "  --out FILE   camera-calibration YAML for spool_detect --camera-info and the node\n"
    "  --flange-diameter M    real flange diameter (default 0.35 m)\n"
    "  --lens-focal-length M  lens focal length for the sensor height (default 0.004 m)\n";

class UsageError : public std::runtime_error
{
  using std::runtime_error::runtime_error;
};

struct Options
{
  std::string csv;
  std::string out;
  std::string camera_name = "spool_camera";
  int width = 0;
  int height = 0;
  double flange_diameter = 0.35;
  double lens_focal_length = 0.004;
};

double parsePositive(const std::string& key, const std::string& text)
{
  std::size_t used = 0;
  double value = 0.0;
  try
  {
    value = std::stod(text, &used);
  }
  catch (const std::exception&)
  {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(value) || value <= 0.0)
    throw UsageError(key + ": expected a positive number, got '" + text + "'");
  return value;
}

int parseSize(const std::string& key, const std::string& text)
{
  const double value = parsePositive(key, text);
  if (value != std::floor(value) || value > 8192)
    throw UsageError(key + ": expected an integer in [1, 8192], got '" + text + "'");
  return static_cast<int>(value);
}

Options parseOptions(int argc, char** argv)
{
  static const std::set<std::string> kKeys = {
      "--csv", "--out", "--width", "--height", "--flange-diameter", "--lens-focal-length", "--camera-name"};
  Options o;
  for (int i = 1; i < argc; ++i)
  {
    const std::string key = argv[i];
    if (key == "--help" || key == "-h")
    {
      std::cout << kUsage;
      std::exit(0);
    }
    if (!kKeys.count(key))
      throw UsageError("unknown option '" + key + "'");
    if (i + 1 >= argc)
      throw UsageError(key + ": missing value");
    const std::string value = argv[++i];
    if (key == "--csv")
      o.csv = value;
    else if (key == "--out")
      o.out = value;
    else if (key == "--width")
      o.width = parseSize(key, value);
    else if (key == "--height")
      o.height = parseSize(key, value);
    else if (key == "--flange-diameter")
      o.flange_diameter = parsePositive(key, value);
    else if (key == "--lens-focal-length")
      o.lens_focal_length = parsePositive(key, value);
    else
      o.camera_name = value;
  }
  if (o.csv.empty())
    throw UsageError("--csv is required");
  if (o.width == 0 || o.height == 0)
    throw UsageError("--width and --height are required (the size the diameters were measured in)");
  return o;
}

int run(const Options& o)
{
  const std::vector<sv::FocalSample> samples = sv::loadFocalSamplesCsv(o.csv);
  const sv::FocalFit fit = sv::fitFocalLength(samples, o.flange_diameter, o.height, o.lens_focal_length);

  std::printf("%-14s %-14s %-14s %-14s\n", "distance_cm", "diameter_px", "residual_px", "sensor_h_cm");
  for (std::size_t i = 0; i < samples.size(); ++i)
    std::printf("%-14.2f %-14.2f %-+14.3f %-14.4f\n", samples[i].distance * 100.0, samples[i].diameter_px,
                fit.residuals_px[i], fit.sensor_heights[i] * 100.0);
  std::printf("samples: %zu\n", samples.size());
  std::printf("focal length: %.2f px at %dx%d (%.1f px at 640x480-equivalent rows)\n", fit.focal_px, o.width, o.height,
              fit.focal_px * 480.0 / o.height);
  std::printf("sensor height (thesis Eq. 3.3, FL = %.2f cm): %.4f cm\n", o.lens_focal_length * 100.0,
              fit.sensor_height * 100.0);
  std::printf("diameter residual: rms %.3f px, max %.3f px\n", fit.rms_px, fit.max_abs_px);

  if (!o.out.empty())
  {
    sv::CameraIntrinsics camera = sv::CameraIntrinsics::thesisDefault(o.width, o.height);
    camera.fx = camera.fy = fit.focal_px;
    std::ofstream out(o.out);
    out << sv::cameraInfoToYaml(camera, o.camera_name);
    if (!out)
      throw std::runtime_error("cannot write " + o.out);
    std::printf("wrote %s\n", o.out.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  Options options;
  try
  {
    options = parseOptions(argc, argv);
  }
  catch (const UsageError& e)
  {
    std::cerr << "spool_calibrate: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try
  {
    return run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << "spool_calibrate: " << e.what() << "\n";
    return 1;
  }
}
