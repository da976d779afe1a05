#include "camera_info_conversion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <image_geometry/pinhole_camera_model.h>
#include <sensor_msgs/distortion_models.h>

#include "spool_vision/detector_params.h"

namespace spool_vision
{
namespace
{
// Sizes whose width and height ratios differ by less than this are one aspect ratio (a C270's
// 1280x720 and 424x240 differ by 0.6%).
constexpr double kAspectTolerance = 0.01;

std::string sizeText(int width, int height)
{
  return std::to_string(width) + "x" + std::to_string(height);
}

std::string number(double value)
{
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

CameraInfoConversion refuse(const std::string& problem)
{
  CameraInfoConversion result;
  result.problem = problem;
  result.refused = true;
  return result;
}

// fx, fy, cx, cy and the distortion of the images `info` describes: K with D for a raw stream
// with distortion, else P (K where P is left zero). False, with `problem` saying why, for a
// distortion model the detector cannot undo.
bool intrinsicsOf(const sensor_msgs::CameraInfo& info, const image_geometry::PinholeCameraModel& model, bool rectified,
                  CameraIntrinsics& camera, std::string& problem, std::string& distortion_ignored)
{
  namespace models = sensor_msgs::distortion_models;
  const bool distorted = std::any_of(info.D.begin(), info.D.end(), [](double d) { return d != 0.0; });
  if (distorted && !rectified)
  {
    const bool plumb_bob = info.distortion_model == models::PLUMB_BOB && info.D.size() == 5;
    const bool rational = info.distortion_model == models::RATIONAL_POLYNOMIAL && info.D.size() == 8;
    if (!plumb_bob && !rational)
    {
      problem = "camera_info's distortion model '" + info.distortion_model + "' with " + std::to_string(info.D.size()) +
                " coefficients is not supported (plumb_bob with 5 or rational_polynomial with 8 are); "
                "calibrate with camera_calibration's default model or feed rectified images";
      return false;
    }
    const cv::Matx33d& k = model.intrinsicMatrix();
    camera.fx = k(0, 0);
    camera.fy = k(1, 1);
    camera.cx = k(0, 2);
    camera.cy = k(1, 2);
    camera.distortion = info.D;
  }
  else
  {
    // P describes the rectified image; a hand-written camera_info may leave it zero, and with
    // no distortion K then describes the same image.
    const cv::Matx34d& p = model.projectionMatrix();
    const cv::Matx33d& k = model.intrinsicMatrix();
    const bool has_p = p(0, 0) > 0.0 && p(1, 1) > 0.0;
    camera.fx = has_p ? p(0, 0) : k(0, 0);
    camera.fy = has_p ? p(1, 1) : k(1, 1);
    camera.cx = has_p ? p(0, 2) : k(0, 2);
    camera.cy = has_p ? p(1, 2) : k(1, 2);
    if (distorted)
      distortion_ignored = std::string("the images are taken for rectified, so they are read with ") +
                           (has_p ? "P" : "K (P is unset)") + " (fx " + number(camera.fx) + ", fy " +
                           number(camera.fy) + " px) and camera_info's non-zero D (the raw image's lens, " +
                           info.distortion_model +
                           ") is not applied again; if these images are raw, set rectified:=false";
  }

  return true;
}
}  // namespace

CameraInfoConversion cameraFromInfo(const sensor_msgs::CameraInfo& info, int image_width, int image_height,
                                    bool rectified)
{
  if (!(info.K[0] > 0.0 && info.K[4] > 0.0 && info.width > 0 && info.height > 0))
  {
    CameraInfoConversion result;
    result.problem = "camera_info is uncalibrated (K[0] = " + number(info.K[0]) + ", K[4] = " + number(info.K[4]) +
                     ", " + sizeText(static_cast<int>(info.width), static_cast<int>(info.height)) + ")";
    return result;
  }

  image_geometry::PinholeCameraModel model;
  model.fromCameraInfo(info);
  CameraIntrinsics camera;
  std::string problem;
  std::string distortion_ignored;
  if (!intrinsicsOf(info, model, rectified, camera, problem, distortion_ignored))
    return refuse(problem);

  // The image the camera_info describes: its ROI (or the full size) reduced by the binning.
  const cv::Rect roi = model.rawRoi();
  const int width = roi.width / static_cast<int>(model.binningX());
  const int height = roi.height / static_cast<int>(model.binningY());
  camera.width = image_width;
  camera.height = image_height;
  CameraInfoConversion result;
  if (width != image_width || height != image_height)
  {
    std::string described = "camera_info describes " + sizeText(width, height) + " images";
    if (width != static_cast<int>(info.width) || height != static_cast<int>(info.height))
      described +=
          " (" + sizeText(static_cast<int>(info.width), static_cast<int>(info.height)) + " with its ROI and binning)";
    const double sx = static_cast<double>(image_width) / width;
    const double sy = static_cast<double>(image_height) / height;
    if (width <= 0 || height <= 0 || std::abs(sx - sy) > kAspectTolerance * std::max(sx, sy))
      return refuse(described + " but the images are " + sizeText(image_width, image_height) +
                    ", another aspect ratio (a crop or another sensor mode, which no scaling describes); "
                    "calibrate the camera at " +
                    sizeText(image_width, image_height) + " or stream it at " + sizeText(width, height));
    camera.fx *= sx;
    camera.cx = (camera.cx + 0.5) * sx - 0.5;
    camera.fy *= sy;
    camera.cy = (camera.cy + 0.5) * sy - 0.5;
    result.scaled = described + " but the images are " + sizeText(image_width, image_height) +
                    "; scaled the calibration by " + number(sx) + " x " + number(sy) + " (fx " + number(camera.fx) +
                    ", fy " + number(camera.fy) + " px). Calibrate at " + sizeText(image_width, image_height) +
                    " for the best accuracy";
  }
  result.camera = camera;
  result.distortion_ignored = distortion_ignored;
  return result;
}

bool isRectifiedStream(const std::string& setting, const std::string& image_topic)
{
  if (setting == "true" || setting == "false")
    return setting == "true";
  if (setting != "auto")
    throw ParamError("rectified", "'" + setting + "' is not allowed; allowed: auto, true or false");
  const std::string name = image_topic.substr(image_topic.find_last_of('/') + 1);
  return name.rfind("image_rect", 0) == 0;
}

sensor_msgs::CameraInfo infoFromCamera(const CameraIntrinsics& camera)
{
  namespace models = sensor_msgs::distortion_models;
  sensor_msgs::CameraInfo info;
  info.width = static_cast<std::uint32_t>(camera.width);
  info.height = static_cast<std::uint32_t>(camera.height);
  info.distortion_model = camera.distortion.size() == 8 ? models::RATIONAL_POLYNOMIAL : models::PLUMB_BOB;
  info.D = camera.distortion;
  info.D.resize(std::max<std::size_t>(info.D.size(), 5), 0.0);
  info.K = {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {camera.fx, 0.0, camera.cx, 0.0, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

bool sameCalibration(const sensor_msgs::CameraInfo& a, const sensor_msgs::CameraInfo& b)
{
  return a.width == b.width && a.height == b.height && a.distortion_model == b.distortion_model && a.D == b.D &&
         a.K == b.K && a.R == b.R && a.P == b.P && a.binning_x == b.binning_x && a.binning_y == b.binning_y &&
         a.roi.x_offset == b.roi.x_offset && a.roi.y_offset == b.roi.y_offset && a.roi.width == b.roi.width &&
         a.roi.height == b.roi.height && a.roi.do_rectify == b.roi.do_rectify;
}

}  // namespace spool_vision
