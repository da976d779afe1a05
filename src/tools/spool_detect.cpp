// spool_detect: runs the detector on images or folders and prints one JSON object per image.
// Contract: ../shared/DESIGN.md §6. Exit 0 = all images processed, 1 = some image failed,
// 2 = bad option or config.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_args.h"
#include "image_file.h"
#include "json_writer.h"
#include "spool_vision/io/config_io.h"
#include "spool_vision/overlay.h"
#include "spool_vision/spool_detector.h"
#include "spool_vision/spool_tracker.h"

namespace fs = std::filesystem;
using spool_vision::JsonObject;

namespace
{
const char* const kUsage =
    "usage: spool_detect [--config FILE] [--camera-info FILE] [--mode mcht|cht] [--overlay DIR]\n"
    "                    [--track] [--rate HZ] PATH...\n"
    "       spool_detect [options] --stdin\n"
    "  PATH       an image (png, jpg, bmp) or a folder of images (in name order)\n"
    "  --config   parameter YAML (default: built-in defaults = config/default.yaml)\n"
    "  --camera-info  ROS camera-calibration YAML: K and D for raw frames (plumb_bob,\n"
    "             rational_polynomial), P when D is zero (rectified); default: the thesis camera\n"
    "  --mode     mcht (concentric constraint, default) or cht (plain CHT, for comparison)\n"
    "  --overlay  write DIR/<image name>.png: the image with what the detector saw (flange,\n"
    "             hole, reference, distance, yaw, state); DIR is created if missing\n"
    "  --track    follow one spool over the images in the order given (SpoolTracker): the\n"
    "             tracked values, plus track_state, track_age, raw_distance, position_covariance,\n"
    "             the puller's misses at the bore's ends and their sigma\n"
    "  --stdin    read one image path per line from standard input and answer each with one JSON\n"
    "             line at once, the tracker's state kept between lines (implies --track); a path\n"
    "             that cannot be read is a dropped frame. A line may instead be a JSON object:\n"
    "             {\"image\": PATH, \"stamp\": S, \"motion\": {\"rotation\": [9 row-major],\n"
    "             \"translation\": [x, y, z]}, \"target_hint\": {\"x\": X, \"y\": Y, \"z\": Z,\n"
    "             \"radius\": M}}, all but image optional: the frame's time (s, increasing), the\n"
    "             camera's motion since the previous frame from odometry (a point fixed in the\n"
    "             scene at p in the previous camera optical frame is at R p + t in this one, m) and\n"
    "             where the task expects the target's bore front centre (this camera's optical\n"
    "             frame, m), as the node takes them from TF and its target_hint topic\n"
    "  --rate     frames per second the images were taken at, for the tracker (default 30)\n"
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
  return JsonObject()
      .add("x", c.x, 2)
      .add("y", c.y, 2)
      .add("r", c.r, 2)
      .add("r_vertical", c.r_vertical, 2)
      .add("r_horizontal", c.r_horizontal > 0.0 ? c.r_horizontal : c.r, 2)
      .add("score", c.score, 3)
      .add("visible_fraction", c.visible_fraction, 3)
      .str();
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

struct Options
{
  std::string config;
  std::string camera_info;
  std::string mode;
  std::string overlay;
  std::vector<std::string> paths;
  bool track = false;
  bool from_stdin = false;
  double rate = 30.0;  ///< Hz: frame i is stamped i / rate
};

Options parseOptions(int argc, char** argv)
{
  const spool_vision::cli::CommandLine line(argc, argv, {"--config", "--camera-info", "--mode", "--overlay", "--rate"},
                                            kUsage, /*allow_positional=*/true, {"--track", "--stdin"});
  Options options{line.text("--config"), line.text("--camera-info"),
                  line.text("--mode"),   line.text("--overlay"),
                  line.positional(),     line.has("--track") || line.has("--stdin"),
                  line.has("--stdin"),   line.positiveNumber("--rate", 30.0)};
  if (options.from_stdin && !options.paths.empty())
    throw spool_vision::cli::UsageError("--stdin reads the image paths from standard input: give no PATH");
  if (!options.from_stdin && options.paths.empty())
    throw spool_vision::cli::UsageError("no PATH given");
  return options;
}

// One frame asked for on --stdin: a path, or a JSON object with the path and what the node takes
// from TF and its target_hint topic.
struct FrameRequest
{
  std::string path;
  std::optional<double> stamp;  ///< s; none: the frame's slot, index / --rate
  std::optional<spool_vision::CameraMotion> motion;
  std::optional<spool_vision::TargetHint> hint;
  std::string error;  ///< why the line is not a request (the frame is then a dropout)
};

// `count` finite numbers from the array `key` of `object`, or std::invalid_argument naming it.
std::vector<double> finiteNumbers(const nlohmann::json& object, const char* key, std::size_t count)
{
  const nlohmann::json& array = object.at(key);
  std::vector<double> values;
  if (array.is_array() && array.size() == count)
    for (const auto& v : array)
      if (v.is_number() && std::isfinite(v.get<double>()))
        values.push_back(v.get<double>());
  if (values.size() != count)
    throw std::invalid_argument(std::string("\"") + key + "\" must be an array of " + std::to_string(count) +
                                " finite numbers");
  return values;
}

double finiteNumber(const nlohmann::json& object, const char* key)
{
  const nlohmann::json& v = object.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw std::invalid_argument(std::string("\"") + key + "\" must be a finite number");
  return v.get<double>();
}

// A line of --stdin. Throws std::invalid_argument on a JSON object that is not a request.
FrameRequest parseJsonRequest(const std::string& line)
{
  const nlohmann::json object = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (!object.is_object())
    throw std::invalid_argument("not a JSON object");
  FrameRequest request;
  if (!object.contains("image") || !object["image"].is_string() || object["image"].get<std::string>().empty())
    throw std::invalid_argument("\"image\" must be the image's path");
  request.path = object["image"].get<std::string>();
  if (object.contains("stamp"))
    request.stamp = finiteNumber(object, "stamp");
  if (object.contains("motion"))
  {
    const nlohmann::json& motion = object["motion"];
    if (!motion.is_object())
      throw std::invalid_argument("\"motion\" must be an object with rotation and translation");
    spool_vision::CameraMotion m;
    const std::vector<double> r = finiteNumbers(motion, "rotation", 9);
    const std::vector<double> t = finiteNumbers(motion, "translation", 3);
    m.rotation = cv::Matx33d(r.data());
    m.translation = {t[0], t[1], t[2]};
    // A rotation matrix, to odometry's rounding: anything else would shear the tracked pose.
    if (cv::norm(m.rotation * m.rotation.t() - cv::Matx33d::eye()) > 1e-3 || cv::determinant(m.rotation) <= 0.0)
      throw std::invalid_argument("\"rotation\" must be a rotation matrix (orthonormal, determinant 1), row-major");
    request.motion = m;
  }
  if (object.contains("target_hint"))
  {
    const nlohmann::json& hint = object["target_hint"];
    if (!hint.is_object())
      throw std::invalid_argument("\"target_hint\" must be an object with x, y, z and radius");
    spool_vision::TargetHint h;
    h.position = {finiteNumber(hint, "x"), finiteNumber(hint, "y"), finiteNumber(hint, "z")};
    h.radius = finiteNumber(hint, "radius");
    if (!(h.radius > 0.0))
      throw std::invalid_argument("\"radius\" of \"target_hint\" must be > 0 m");
    request.hint = h;
  }
  return request;
}

// A line of --stdin: a path, or a JSON request (with `error` set when it is not one).
FrameRequest parseRequest(const std::string& line)
{
  if (line.front() != '{')
    return FrameRequest{line, std::nullopt, std::nullopt, std::nullopt, ""};
  try
  {
    return parseJsonRequest(line);
  }
  catch (const std::exception& e)
  {
    return FrameRequest{line, std::nullopt, std::nullopt, std::nullopt, std::string("bad request: ") + e.what()};
  }
}

// The detector of --config, --mode and --camera-info (`params`, `camera`: what they set); a
// file or value they name that cannot be used is a usage error. Makes the --overlay folder.
void setUp(const Options& options, spool_vision::DetectorParams& params,
           std::optional<spool_vision::CameraIntrinsics>& camera,
           std::optional<spool_vision::TrackingDetector>& detector)
{
  try
  {
    if (!options.config.empty())
      spool_vision::loadParamsYaml(options.config, params);
    if (!options.mode.empty())
      spool_vision::setParam(params, "mode", options.mode);
    if (!options.camera_info.empty())
      camera = spool_vision::loadCameraInfoYaml(options.camera_info);
    detector.emplace(params);
  }
  catch (const std::exception& e)
  {
    throw spool_vision::cli::UsageError(e.what(), /*show_usage=*/false);
  }
  if (camera)
    detector->detector().setCamera(*camera);
  if (!options.overlay.empty())
  {
    std::error_code ec;
    fs::create_directories(options.overlay, ec);
    if (!fs::is_directory(options.overlay))
      throw spool_vision::cli::UsageError(
          "--overlay: cannot create the folder " + options.overlay + (ec ? " (" + ec.message() + ")" : ""),
          /*show_usage=*/false);
  }
}

// The axis from the bore's parallax: where the lens's centroid lies (px), the yaw of the axis it
// gives (rad, atan of the slope x/z) and its 1-sigma. Its pitch is not printed: the tracker
// leaves it to the rim (biased 0.2-0.3 deg on rendered approaches).
std::string boreParallaxJson(const spool_vision::SpoolDetection& d)
{
  if (!d.parallax_measured)
    return "null";
  return JsonObject()
      .add("lens_x", d.lens_centroid.x, 2)
      .add("lens_y", d.lens_centroid.y, 2)
      .add("yaw", std::atan(d.parallax_slopes[0]), 5)
      .add("yaw_sigma", std::sqrt(d.parallax_covariance(0, 0)), 5)
      .str();
}

// One detection's fields, after "image".
void addDetection(const spool_vision::ImageFile& file, const spool_vision::SpoolDetection& d, JsonObject& out)
{
  out.add("width", file.image.cols)
      .add("height", file.image.rows)
      .add("detected", d.detected)
      .add("hole_detected", d.hole_detected)
      .add("distance", d.distance)
      .add("range", d.range)
      .add("yaw", d.yaw, 5)
      .add("overlapped", d.overlapped)
      .add("aligned", d.aligned)
      .add("lateral_offset", d.lateral_offset, 5)
      .addRaw("position",
              d.detected
                  ? JsonObject().add("x", d.position.x, 5).add("y", d.position.y, 5).add("z", d.position.z, 5).str()
                  : "null")
      .addRaw("axis", std::isfinite(d.axis[2])
                          ? JsonObject().add("x", d.axis[0], 5).add("y", d.axis[1], 5).add("z", d.axis[2], 5).str()
                          : "null")
      .add("axis_angle", d.axis_angle, 5)
      .add("axis_yaw", d.axis_yaw, 5)
      .addRaw("flange", circleJson(d.detected, d.flange))
      .addRaw("hole", circleJson(d.hole_detected, d.hole))
      .addRaw("lens", circleJson(d.lens_detected, d.lens))
      .addRaw("bore_parallax", boreParallaxJson(d))
      .add("confidence", d.confidence, 3)
      .addRaw("reference", JsonObject().add("x", d.reference.x, 2).add("y", d.reference.y, 2).str())
      .add("time_ms", d.time_ms, 3);
}

// The tracker's fields, after the tracked detection's.
void addTrack(const spool_vision::TrackedFrame& frame, JsonObject& out)
{
  const spool_vision::TrackedSpool& t = frame.track;
  out.add("track_state", spool_vision::toString(t.state))
      .add("track_age", t.age)
      .add("rejected", t.rejected)
      .add("raw_distance", frame.raw.detected ? frame.raw.distance : spool_vision::SpoolDetection::kNaN);
  if (frame.published.detected)
    out.addArray("position_covariance", std::vector<double>(t.position_covariance.val, t.position_covariance.val + 9));
  else
    out.addRaw("position_covariance", "null");
  out.add("axis_sigma", t.axis_sigma, 5)
      .add("axis_cue", spool_vision::toString(t.axis_cue))
      .add("front_miss", t.front_miss, 5)
      .add("back_miss", t.back_miss, 5)
      .add("miss_sigma", t.miss_sigma, 5)
      .add("full_search", frame.full_search);
}

// The detector (and tracker) of one run, answering one image at a time.
class ImageRunner
{
public:
  explicit ImageRunner(const Options& options) : options_(options)
  {
    setUp(options_, params_, camera_, detector_);
  }

  /// One image's line; `failed` is set when the image could not be processed. Every image is a
  /// frame slot (i / --rate, or the request's stamp), read or not: a frame that cannot be read is
  /// a dropout for the tracker.
  JsonObject process(const FrameRequest& request, bool& failed)
  {
    const std::string& path = request.path;
    JsonObject out;
    out.add("image", path);
    const double stamp = request.stamp.value_or(frame_index_ / options_.rate);
    ++frame_index_;
    try
    {
      if (!request.error.empty())
        throw std::invalid_argument(request.error);
      if (last_stamp_ && !(stamp > *last_stamp_))
        throw std::invalid_argument("\"stamp\" " + std::to_string(stamp) + " s does not follow the frame before (" +
                                    std::to_string(*last_stamp_) + " s): stamps must increase");
      last_stamp_ = stamp;
      const spool_vision::ImageFile file = spool_vision::readImageFile(path);
      spool_vision::TrackedFrame frame;
      if (options_.track)
        frame = detector_->process(file.image, file.format, stamp, request.motion, request.hint);
      else
        frame.published = detector_->detector().detect(file.image, file.format);
      sayFallbackOnce();
      addDetection(file, frame.published, out);
      if (options_.track)
        addTrack(frame, out);
      if (!options_.overlay.empty())
        out.add("overlay", writeOverlay(path, file, frame.published));
    }
    catch (const std::exception& e)
    {
      out.add("error", e.what());
      failed = true;
    }
    return out;
  }

private:
  void sayFallbackOnce()
  {
    if (!detector_->detector().usingFallbackCamera() || fallback_said_)
      return;
    std::cerr << "spool_detect: " << (camera_ ? "camera info does not match the image size; " : "no camera info; ")
              << "using the thesis camera (f = " << params_.geometry.fallback_focal_length
              << " px at 120 rows, scaled)\n";
    fallback_said_ = true;
  }

  // Same name as the image, as png: lossless, so the thin lines and text stay sharp.
  std::string writeOverlay(const std::string& path, const spool_vision::ImageFile& file,
                           const spool_vision::SpoolDetection& d) const
  {
    const std::string overlay = (fs::path(options_.overlay) / fs::path(path).stem()).string() + ".png";
    if (!cv::imwrite(overlay, spool_vision::renderOverlay(file.image, file.format, d)))
      throw std::runtime_error("cannot write the overlay " + overlay);
    return overlay;
  }

  const Options& options_;
  spool_vision::DetectorParams params_;
  std::optional<spool_vision::CameraIntrinsics> camera_;
  std::optional<spool_vision::TrackingDetector> detector_;
  bool fallback_said_ = false;
  int frame_index_ = 0;
  std::optional<double> last_stamp_;
};

int run(int argc, char** argv)
{
  const Options options = parseOptions(argc, argv);
  ImageRunner runner(options);
  bool any_failed = false;
  auto answer = [&](const FrameRequest& request)
  {
    // Flushed: a program driving --stdin waits for each line.
    std::cout << runner.process(request, any_failed).str() << std::endl;
  };
  if (options.from_stdin)
  {
    for (std::string line; std::getline(std::cin, line);)
      if (!line.empty())
        answer(parseRequest(line));
  }
  else
  {
    for (const auto& path : expand(options.paths))
      answer(FrameRequest{path, std::nullopt, std::nullopt, std::nullopt, ""});
  }
  return any_failed ? 1 : 0;
}
}  // namespace

int main(int argc, char** argv)
{
  return spool_vision::cli::runTool("spool_detect", kUsage, [&] { return run(argc, argv); });
}
