// spool_calibrate: fits the focal length (and the thesis' "sensor height") from flange
// diameters at tape-measured distances and writes a ROS camera-calibration YAML. The diameters
// come from a CSV of measurements or are measured by the detector in images of the spool.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli_args.h"
#include "image_file.h"
#include "spool_vision/focal_calibration.h"
#include "spool_vision/io/calibration_csv.h"
#include "spool_vision/io/config_io.h"
#include "spool_vision/spool_detector.h"

namespace sv = spool_vision;
using sv::cli::UsageError;

namespace
{
const char* const kUsage =
    "usage: spool_calibrate --csv FILE --width W --height H [options]\n"
    "       spool_calibrate --images FILE [--config FILE] [options]\n"
    "  --csv FILE     pairs of measured distance and observed flange diameter: '#' comments, a\n"
    "                 header naming a distance column (suffix _m, _cm or _mm) and a px column\n"
    "                 (e.g. measured_distance_cm,object_height_px)\n"
    "  --width W --height H   the image size the diameters were measured in (with --csv)\n"
    "  --images FILE  spool images at measured distances: a CSV with an 'image' and a distance\n"
    "                 column (e.g. image,distance_m); relative paths are from the CSV's folder.\n"
    "                 The detector measures each flange; images without one are skipped\n"
    "  --config FILE  detector parameter YAML (default: built-in defaults) for --images; the\n"
    "                 flange radius range is searched wide unless it sets both flange_radius_min/max\n"
    "options:\n"
    "  --out FILE     camera-calibration YAML for spool_detect --camera-info and the node\n"
    "  --flange-diameter M    real flange diameter (default: the config's flange_diameter, 0.35 m)\n"
    "  --lens-focal-length M  lens focal length for the sensor height (default 0.004 m)\n"
    "  --camera-name NAME     camera_name in the YAML (default spool_camera)\n"
    "Exit: 0 ok, 1 failed (unreadable file, fewer than 2 usable images), 2 bad option or config.\n";

struct Options
{
  std::string csv;
  std::string images;
  std::string config;
  std::string out;
  std::string camera_name = "spool_camera";
  int width = 0;
  int height = 0;
  double flange_diameter = 0.0;  // m, 0 = the config's flange_diameter
  double lens_focal_length = 0.004;
};

Options parseOptions(int argc, char** argv)
{
  const sv::cli::CommandLine line(argc, argv,
                                  {"--csv", "--images", "--config", "--out", "--width", "--height", "--flange-diameter",
                                   "--lens-focal-length", "--camera-name"},
                                  kUsage);
  Options o;
  o.csv = line.text("--csv");
  o.images = line.text("--images");
  o.config = line.text("--config");
  o.out = line.text("--out");
  o.camera_name = line.text("--camera-name", o.camera_name);
  o.width = line.positiveInteger("--width", 8192, 0);
  o.height = line.positiveInteger("--height", 8192, 0);
  o.flange_diameter = line.positiveNumber("--flange-diameter", 0.0);
  o.lens_focal_length = line.positiveNumber("--lens-focal-length", o.lens_focal_length);
  if (o.csv.empty() == o.images.empty())
    throw UsageError("give either --csv or --images");
  if (!o.csv.empty() && (o.width == 0 || o.height == 0))
    throw UsageError("--width and --height are required with --csv (the size the diameters were measured in)");
  if (!o.images.empty() && (o.width != 0 || o.height != 0))
    throw UsageError("--width/--height go with --csv; --images takes the size from the images");
  return o;
}

// The detector parameters: defaults, the config file, then --flange-diameter. A bad value is a
// bad configuration (exit 2).
sv::DetectorParams loadParams(const Options& o)
{
  sv::DetectorParams params;
  try
  {
    if (!o.config.empty())
      sv::loadParamsYaml(o.config, params);
    if (o.flange_diameter > 0.0)
      sv::setParam(params, "flange_diameter", o.flange_diameter);
    sv::validateParams(params);
  }
  catch (const std::exception& e)
  {
    throw UsageError(e.what(), /*show_usage=*/false);
  }
  return params;
}

// Diameters measured by the detector, one per image in which it finds the flange; the other
// images are reported on stderr. Sets `size` from the first readable image.
std::vector<sv::FocalSample> measureImages(const std::vector<sv::CalibrationImage>& images, sv::DetectorParams params,
                                           std::vector<std::string>& labels, cv::Size& size)
{
  // The detector derives its radius range from the focal length this tool is about to measure;
  // unless the config fixes the range, search every radius a plausible camera could give.
  const bool derived_range = !(params.hough.flange_radius_min > 0.0 && params.hough.flange_radius_max > 0.0);
  sv::SpoolDetector detector(params);
  std::vector<sv::FocalSample> samples;
  for (const sv::CalibrationImage& entry : images)
  {
    try
    {
      const sv::ImageFile file = sv::readImageFile(entry.path);
      if (size.empty())
        size = file.image.size();
      if (file.image.size() != size)
        throw std::runtime_error("it is " + std::to_string(file.image.cols) + "x" + std::to_string(file.image.rows) +
                                 ", the first image " + std::to_string(size.width) + "x" + std::to_string(size.height));
      if (derived_range)
      {
        sv::calibrationRadiusRange(entry.distance, params.geometry.flange_diameter, size.width,
                                   params.hough.flange_radius_min, params.hough.flange_radius_max);
        detector.setParams(params);
      }
      detector.detect(file.image, file.format);
      // The strongest rim, not the detector's target: the target is the flange nearest the
      // puller reference, whose image position depends on the unknown focal length too.
      const std::vector<sv::Circle>& flanges = detector.flangeCandidates();
      if (flanges.empty())
        throw std::runtime_error("no flange found");
      const sv::Circle& flange = *std::max_element(
          flanges.begin(), flanges.end(), [](const sv::Circle& a, const sv::Circle& b) { return a.score < b.score; });
      samples.push_back({entry.distance, 2.0 * flange.r_vertical});
      labels.push_back(entry.path);
    }
    catch (const std::exception& e)
    {
      std::cerr << "spool_calibrate: skipped " << entry.path << ": " << e.what() << "\n";
    }
  }
  return samples;
}

void printFit(const std::vector<sv::FocalSample>& samples, const std::vector<std::string>& labels,
              const sv::FocalFit& fit, cv::Size size, double lens_focal_length)
{
  std::printf("%-14s %-14s %-14s %-14s%s\n", "distance_cm", "diameter_px", "residual_px", "sensor_h_cm",
              labels.empty() ? "" : " image");
  for (std::size_t i = 0; i < samples.size(); ++i)
    std::printf("%-14.2f %-14.2f %-+14.3f %-14.4f%s%s\n", samples[i].distance * 100.0, samples[i].diameter_px,
                fit.residuals_px[i], fit.sensor_heights[i] * 100.0, labels.empty() ? "" : " ",
                labels.empty() ? "" : labels[i].c_str());
  std::printf("samples: %zu\n", samples.size());
  std::printf("focal length: %.2f px at %dx%d (%.1f px at 640x480-equivalent rows)\n", fit.focal_px, size.width,
              size.height, fit.focal_px * 480.0 / size.height);
  std::printf("sensor height (thesis Eq. 3.3, FL = %.2f cm): %.4f cm\n", lens_focal_length * 100.0,
              fit.sensor_height * 100.0);
  std::printf("diameter residual: rms %.3f px, max %.3f px\n", fit.rms_px, fit.max_abs_px);
}

int run(int argc, char** argv)
{
  const Options o = parseOptions(argc, argv);
  const sv::DetectorParams params = loadParams(o);

  std::vector<sv::FocalSample> samples;
  std::vector<std::string> labels;
  cv::Size size(o.width, o.height);
  if (!o.csv.empty())
    samples = sv::loadFocalSamplesCsv(o.csv);
  else
  {
    const std::vector<sv::CalibrationImage> images = sv::loadCalibrationImagesCsv(o.images);
    samples = measureImages(images, params, labels, size);
    if (samples.size() < 2)
      throw std::runtime_error("the flange was found in " + std::to_string(samples.size()) + " of " +
                               std::to_string(images.size()) + " images; the fit needs at least 2");
  }
  const sv::FocalFit fit =
      sv::fitFocalLength(samples, params.geometry.flange_diameter, size.height, o.lens_focal_length);
  printFit(samples, labels, fit, size, o.lens_focal_length);

  if (!o.out.empty())
  {
    sv::CameraIntrinsics camera = sv::CameraIntrinsics::thesisDefault(size.width, size.height);
    camera.fx = camera.fy = fit.focal_px;
    sv::saveCameraInfoYaml(o.out, camera, o.camera_name);
    std::printf("wrote %s\n", o.out.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  return sv::cli::runTool("spool_calibrate", kUsage, [&] { return run(argc, argv); });
}
