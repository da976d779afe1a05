#include "spool_detector_ros.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <string>

#include <cv_bridge/cv_bridge.h>
#include <image_transport/exception.h>
#include <sensor_msgs/image_encodings.h>
#include <boost/any.hpp>
#include <opencv2/imgproc.hpp>

#include "pose_conversion.h"
#include "ros_params.h"
#include "spool_vision/overlay.h"

namespace spool_vision
{
namespace
{
namespace enc = sensor_msgs::image_encodings;

// Bad input can arrive at frame rate; one line per period is enough to see it in the log.
constexpr double kErrorThrottlePeriod = 5.0;
constexpr std::size_t kMaxErrorKinds = 64;

std::optional<PixelFormat> pixelFormatOf(const std::string& encoding)
{
  if (encoding == enc::MONO8)
    return PixelFormat::kMono8;
  if (encoding == enc::MONO16)
    return PixelFormat::kMono16;
  if (encoding == enc::BGR8)
    return PixelFormat::kBgr8;
  if (encoding == enc::RGB8)
    return PixelFormat::kRgb8;
  if (encoding == enc::BGRA8)
    return PixelFormat::kBgra8;
  if (encoding == enc::RGBA8)
    return PixelFormat::kRgba8;
  return std::nullopt;
}

// YUYV as webcam drivers (usb_cam, v4l2_camera) publish it; Debian's cv_bridge does not know the
// name. "yuv422" is UYVY. Both carry the luma the detector reads in every other byte.
const char* const kYuyv = "yuv422_yuy2";

// cv_bridge wraps msg.data without checking its size, so a short buffer would be read past its
// end: refuse it before any conversion.
void checkBuffer(const sensor_msgs::Image& msg)
{
  if (msg.width == 0 || msg.height == 0)
    throw std::invalid_argument("empty image (" + std::to_string(msg.width) + "x" + std::to_string(msg.height) + ")");
  size_t bits_per_pixel = 0;
  try
  {
    bits_per_pixel =
        msg.encoding == kYuyv ? 16 : static_cast<size_t>(enc::bitDepth(msg.encoding)) * enc::numChannels(msg.encoding);
  }
  catch (const std::runtime_error&)
  {
    throw std::invalid_argument("unknown encoding '" + msg.encoding + "'");
  }
  if (static_cast<size_t>(msg.step) * 8 < static_cast<size_t>(msg.width) * bits_per_pixel)
    throw std::invalid_argument("step " + std::to_string(msg.step) + " is too small for " + std::to_string(msg.width) +
                                " " + msg.encoding + " pixels");
  if (msg.data.size() < static_cast<size_t>(msg.step) * msg.height)
    throw std::invalid_argument("data holds " + std::to_string(msg.data.size()) + " bytes, step x height needs " +
                                std::to_string(static_cast<size_t>(msg.step) * msg.height));
}

template <typename T>
T readRosOption(const ros::NodeHandle& pnh, const std::string& key, const T& fallback, const char* expected)
{
  T value = fallback;
  if (pnh.hasParam(key) && !pnh.getParam(key, value))
    throw ParamError(key, std::string("expected ") + expected);
  return value;
}

}  // namespace

const std::set<std::string>& SpoolDetectorRos::rosKeys()
{
  static const std::set<std::string> keys = {"image_transport", "queue_size", "min_rate", "max_rate",
                                             "diagnostic_period"};
  return keys;
}

SpoolDetectorRos::SpoolDetectorRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name)
  : nh_(nh), pnh_(pnh), it_(nh), private_it_(pnh), updater_(nh, pnh, name)
{
  DetectorParams params;
  loadParamsFromRos(pnh_, rosKeys(), params);
  detector_.setParams(params);

  const auto transport = readRosOption<std::string>(pnh_, "image_transport", "raw", "a transport name such as raw");
  const int queue_size = readRosOption<int>(pnh_, "queue_size", 2, "an integer in [1, 1000]");
  if (queue_size < 1 || queue_size > 1000)
    throw ParamError("queue_size", std::to_string(queue_size) + " is out of range; allowed: an integer in [1, 1000]");
  min_rate_ = readRosOption<double>(pnh_, "min_rate", 5.0, "a number in Hz");
  max_rate_ = readRosOption<double>(pnh_, "max_rate", 60.0, "a number in Hz");
  if (!(min_rate_ > 0.0 && max_rate_ >= min_rate_))
    throw ParamError("max_rate", "min_rate and max_rate must satisfy 0 < min_rate <= max_rate");

  // The dynamic_reconfigure server starts from the parameter server: give it the values in
  // force (YAML on top of the defaults) so that it neither resets nor clamps anything.
  for (const auto& description : SpoolDetectorConfig::__getParamDescriptions__())
  {
    const ParamSpec* spec = findParamSpec(description->name);
    if (!spec)
      throw std::logic_error("cfg/SpoolDetector.cfg key '" + description->name + "' is not a detector key");
    setRosParam(pnh_, spec->key, spec->get(detector_.params()));
  }
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<SpoolDetectorConfig>>(pnh_);
  reconfigure_server_->setCallback([this](SpoolDetectorConfig& config, uint32_t level)
                                   { reconfigureCallback(config, level); });

  if (!(updater_.getPeriod() > 0.0))
    throw ParamError("diagnostic_period", "must be a positive number of seconds");
  updater_.setHardwareID("spool_vision");
  frequency_status_ = std::make_unique<diagnostic_updater::FrequencyStatus>(
      diagnostic_updater::FrequencyStatusParam(&min_rate_, &max_rate_, 0.1, 10), "Frame rate");
  updater_.add(*frequency_status_);
  updater_.add("Processing", this, &SpoolDetectorRos::diagnoseProcessing);
  // Wall time: diagnostics keep coming while a replayed clock is paused.
  diagnostics_timer_ = nh_.createWallTimer(ros::WallDuration(updater_.getPeriod()),
                                           [this](const ros::WallTimerEvent&) { updater_.force_update(); });

  pose_pub_ = nh_.advertise<SpoolPose>("spool_pose", 10);
  debug_pub_ = private_it_.advertise("debug_image", 1);
  camera_info_sub_ = nh_.subscribe("camera_info", queue_size, &SpoolDetectorRos::cameraInfoCallback, this);
  try
  {
    // Hints read ~image_transport (already checked above) rather than a global parameter.
    image_sub_ = it_.subscribe("image", queue_size, &SpoolDetectorRos::imageCallback, this,
                               image_transport::TransportHints(transport, ros::TransportHints(), pnh_));
  }
  catch (const image_transport::TransportLoadException& e)
  {
    throw ParamError("image_transport", "transport '" + transport + "' cannot be loaded (" + e.what() + ")");
  }
  ROS_INFO("spool_detector: listening on %s (%s) and %s, publishing %s", image_sub_.getTopic().c_str(),
           image_sub_.getTransport().c_str(), camera_info_sub_.getTopic().c_str(), pose_pub_.getTopic().c_str());
}

void SpoolDetectorRos::reconfigureCallback(SpoolDetectorConfig& config, uint32_t /*level*/)
{
  DetectorParams params = detector_.params();
  try
  {
    for (const auto& description : SpoolDetectorConfig::__getParamDescriptions__())
    {
      boost::any value;
      description->getValue(config, value);
      if (description->type == "str")
        setParam(params, description->name, boost::any_cast<std::string>(value));
      else if (description->type == "int")
        setParam(params, description->name, boost::any_cast<int>(value));
      else if (description->type == "double")
        setParam(params, description->name, boost::any_cast<double>(value));
      else
        setParam(params, description->name, boost::any_cast<bool>(value));
    }
    detector_.setParams(params);
    applied_config_ = config;
  }
  catch (const ParamError& e)
  {
    // The server publishes `config` after this returns: hand back the settings still in force.
    ROS_ERROR("spool_detector: rejected reconfigure request: %s; keeping the previous settings", e.what());
    if (applied_config_)
      config = *applied_config_;
  }
}

void SpoolDetectorRos::cameraInfoCallback(const sensor_msgs::CameraInfoConstPtr& msg)
{
  const auto& k = msg->K;
  if (k[0] > 0.0 && k[4] > 0.0 && msg->width > 0 && msg->height > 0)
  {
    // K, not P: the detector sees the image as published (image_raw from a webcam); subscribe
    // to image_rect with its own camera_info to use rectified frames.
    CameraIntrinsics camera;
    camera.fx = k[0];
    camera.fy = k[4];
    camera.cx = k[2];
    camera.cy = k[5];
    camera.width = static_cast<int>(msg->width);
    camera.height = static_cast<int>(msg->height);
    if (!info_camera_ || *info_camera_ != camera)
    {
      detector_.setCamera(camera);
      info_camera_ = camera;
      camera_problem_.clear();
    }
    return;
  }
  if (info_camera_)
  {
    detector_.clearCamera();
    info_camera_.reset();
  }
  camera_problem_ = "camera_info on " + camera_info_sub_.getTopic() +
                    " is uncalibrated (K[0] = " + std::to_string(k[0]) + ", K[4] = " + std::to_string(k[4]) + ", " +
                    std::to_string(msg->width) + "x" + std::to_string(msg->height) + ")";
}

void SpoolDetectorRos::imageCallback(const sensor_msgs::ImageConstPtr& msg)
{
  const ros::WallTime start = ros::WallTime::now();
  try
  {
    processImage(msg);
  }
  catch (const std::exception& e)
  {
    // cv_bridge::Exception, cv::Exception and std::invalid_argument (bad image) all land here;
    // the controller still gets a message for the frame, with nothing detected.
    if (shouldLogError(msg->encoding, e.what()))
      ROS_ERROR("spool_detector: cannot process image %u (%s, %ux%u): %s", msg->header.seq, msg->encoding.c_str(),
                msg->width, msg->height, e.what());
    const auto& g = detector_.params().geometry;
    pose_pub_.publish(undefinedSpoolPose(msg->header, (g.hole_diameter - g.puller_diameter) / 2.0));
    ++window_failed_;
  }
  frequency_status_->tick();
  window_callback_ms_ += (ros::WallTime::now() - start).toSec() * 1000.0;
}

bool SpoolDetectorRos::shouldLogError(const std::string& encoding, const std::string& what)
{
  // One line per kind of error and period: the kind is the encoding and the message without its
  // numbers (sizes, byte counts), so a different problem is never hidden behind an earlier one.
  std::string kind = encoding + ": ";
  for (const char c : what)
    if (!std::isdigit(static_cast<unsigned char>(c)))
      kind += c;
  const ros::WallTime now = ros::WallTime::now();
  if (last_error_log_.size() > kMaxErrorKinds)
    last_error_log_.clear();  // bounded: garbage input can make up endless kinds
  const auto it = last_error_log_.find(kind);
  if (it != last_error_log_.end() && (now - it->second).toSec() < kErrorThrottlePeriod)
    return false;
  last_error_log_[kind] = now;
  return true;
}

void SpoolDetectorRos::processImage(const sensor_msgs::ImageConstPtr& msg)
{
  checkBuffer(*msg);
  cv_bridge::CvImageConstPtr frame;
  cv::Mat image;
  PixelFormat format = PixelFormat::kMono8;
  const int rows = static_cast<int>(msg->height);
  const int cols = static_cast<int>(msg->width);
  auto* data = const_cast<uint8_t*>(msg->data.data());  // read only: wrapped, never written
  if (msg->encoding == kYuyv || msg->encoding == enc::YUV422)
  {
    const cv::Mat packed(rows, cols, CV_8UC2, data, msg->step);
    cv::cvtColor(packed, converted_, msg->encoding == kYuyv ? cv::COLOR_YUV2GRAY_YUY2 : cv::COLOR_YUV2GRAY_UYVY);
    image = converted_;
  }
  else if (msg->encoding == enc::MONO16 && msg->is_bigendian)
  {
    // cv_bridge fails on big-endian words; this host reads them little-endian: swap the bytes.
    converted_.create(rows, cols, CV_16UC1);
    for (int y = 0; y < rows; ++y)
    {
      const uint8_t* in = data + static_cast<size_t>(y) * msg->step;
      auto* out = converted_.ptr<uint16_t>(y);
      for (int x = 0; x < cols; ++x)
        out[x] = static_cast<uint16_t>((in[2 * x] << 8) | in[2 * x + 1]);
    }
    image = converted_;
    format = PixelFormat::kMono16;
  }
  else if (const auto direct = pixelFormatOf(msg->encoding))
  {
    frame = cv_bridge::toCvShare(msg);
    image = frame->image;
    format = *direct;
  }
  else
  {
    // Bayer (all four patterns) and 16-bit colour are converted; encodings without a colour
    // meaning (depth, float) make cv_bridge throw.
    frame = cv_bridge::toCvShare(msg, enc::MONO8);
    image = frame->image;
  }

  const SpoolDetection detection = detector_.detect(image, format);
  reportCameraSource(*msg);
  pose_pub_.publish(toSpoolPose(detection, msg->header));

  ++window_frames_;
  window_detected_ += detection.detected ? 1 : 0;
  window_detector_ms_ += detection.time_ms;
  window_detector_max_ms_ = std::max(window_detector_max_ms_, detection.time_ms);

  if (debug_pub_.getNumSubscribers() > 0)
    debug_pub_.publish(
        cv_bridge::CvImage(msg->header, enc::BGR8, renderOverlay(image, format, detection)).toImageMsg());
}

void SpoolDetectorRos::reportCameraSource(const sensor_msgs::Image& msg)
{
  if (!detector_.usingFallbackCamera())
  {
    if (fallback_reported_)
      ROS_INFO("spool_detector: using the camera_info intrinsics (fx %.1f, fy %.1f px)", info_camera_->fx,
               info_camera_->fy);
    fallback_reported_ = false;
    return;
  }
  if (fallback_reported_)
    return;
  std::string why = camera_problem_;
  if (info_camera_)
    why = "camera_info is for " + std::to_string(info_camera_->width) + "x" + std::to_string(info_camera_->height) +
          " but the images are " + std::to_string(msg.width) + "x" + std::to_string(msg.height);
  const double focal = detector_.params().geometry.fallback_focal_length * msg.height / 120.0;
  ROS_WARN(
      "spool_detector: %s; falling back to the thesis camera (f = %.1f px for %ux%u, principal point at "
      "the image centre). Distances and angles are only as good as that guess: calibrate the camera.",
      why.c_str(), focal, msg.width, msg.height);
  fallback_reported_ = true;
}

void SpoolDetectorRos::diagnoseProcessing(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  using diagnostic_msgs::DiagnosticStatus;
  if (window_failed_ > 0)
    status.summaryf(DiagnosticStatus::WARN, "%d frames could not be processed", window_failed_);
  else if (detector_.usingFallbackCamera() && window_frames_ > 0)
    status.summary(DiagnosticStatus::WARN, "no valid camera_info: using the thesis camera");
  else
    status.summary(DiagnosticStatus::OK, "ok");

  status.add("Frames", window_frames_);
  status.add("Failed frames", window_failed_);
  status.add("Detected frames", window_detected_);
  if (window_frames_ > 0)
  {
    status.addf("Detection rate (%)", "%.1f", 100.0 * window_detected_ / window_frames_);
    status.addf("Detector time mean (ms)", "%.2f", window_detector_ms_ / window_frames_);
    status.addf("Detector time max (ms)", "%.2f", window_detector_max_ms_);
  }
  const int callbacks = window_frames_ + window_failed_;
  if (callbacks > 0)
    status.addf("Callback time mean (ms)", "%.2f", window_callback_ms_ / callbacks);
  status.add("Camera", detector_.usingFallbackCamera() ? "thesis fallback" : "camera_info");

  window_frames_ = window_detected_ = window_failed_ = 0;
  window_detector_ms_ = window_detector_max_ms_ = window_callback_ms_ = 0.0;
}

}  // namespace spool_vision
