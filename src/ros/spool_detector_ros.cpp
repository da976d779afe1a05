#include "spool_detector_ros.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_transport/camera_common.h>
#include <image_transport/exception.h>
#include <ros/master.h>
#include <sensor_msgs/image_encodings.h>
#include <visualization_msgs/Marker.h>
#include <boost/any.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera_info_conversion.h"
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
// How long without a processed frame before checking whether camera_info is published at all.
constexpr double kCameraInfoCheckPeriod = 5.0;
// "Frame age" bounds (s): TimeStampStatus's defaults, a second early to five seconds late.
constexpr double kMinFrameAge = -1.0;
constexpr double kMaxFrameAge = 5.0;
// image_transport's name for the compressed transport and its topic suffix.
const char* const kCompressed = "compressed";
const std::string kCompressedSuffix = "/compressed";

bool endsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The encodings the core reads as they are (cv_bridge shares their buffer).
std::optional<PixelFormat> pixelFormatOf(const std::string& encoding)
{
  static const std::map<std::string, PixelFormat> kDirect = {
      {enc::MONO8, PixelFormat::kMono8}, {enc::MONO16, PixelFormat::kMono16}, {enc::BGR8, PixelFormat::kBgr8},
      {enc::RGB8, PixelFormat::kRgb8},   {enc::BGRA8, PixelFormat::kBgra8},   {enc::RGBA8, PixelFormat::kRgba8}};
  const auto it = kDirect.find(encoding);
  return it == kDirect.end() ? std::nullopt : std::optional<PixelFormat>(it->second);
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

// cv::imdecode leaves its target as it was when it cannot read the data's header, and says
// nothing else: a reused buffer would hand on the previous frame. Its first row is set to this
// pattern before each decode (a decoded frame overwrites it; no camera row equals it).
uint8_t staleMark(size_t i)
{
  return static_cast<uint8_t>(i * 7 + 13);
}

void markStale(cv::Mat& buffer)
{
  if (buffer.empty())
    return;
  uint8_t* row = buffer.ptr<uint8_t>(0);
  for (size_t i = 0; i < buffer.cols * buffer.elemSize(); ++i)
    row[i] = staleMark(i);
}

bool isStale(const cv::Mat& buffer)
{
  if (buffer.empty())
    return true;
  const uint8_t* row = buffer.ptr<uint8_t>(0);
  for (size_t i = 0; i < buffer.cols * buffer.elemSize(); ++i)
    if (row[i] != staleMark(i))
      return false;
  return true;
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
  static const std::set<std::string> keys = {
      "image_transport", "queue_size", "min_rate", "max_rate",   "diagnostic_period", "use_camera_info",   "publish_tf",
      "spool_frame",     "rectified",  "track",    "odom_frame", "odom_timeout",      "target_hint_radius"};
  return keys;
}

SpoolDetectorRos::SpoolDetectorRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name)
  : nh_(nh), pnh_(pnh), it_(nh), private_it_(pnh), updater_(nh, pnh, name)
{
  DetectorParams params;
  loadParamsFromRos(pnh_, rosKeys(), params);
  tracking_.setParams(params);

  const auto transport = readRosOption<std::string>(pnh_, "image_transport", "raw", "a transport name such as raw");
  const int queue_size = readRosOption<int>(pnh_, "queue_size", 2, "an integer in [1, 1000]");
  if (queue_size < 1 || queue_size > 1000)
    throw ParamError("queue_size", std::to_string(queue_size) + " is out of range; allowed: an integer in [1, 1000]");
  min_rate_ = readRosOption<double>(pnh_, "min_rate", 5.0, "a number in Hz");
  max_rate_ = readRosOption<double>(pnh_, "max_rate", 60.0, "a number in Hz");
  if (!(min_rate_ > 0.0 && max_rate_ >= min_rate_))
    throw ParamError("max_rate", "min_rate and max_rate must satisfy 0 < min_rate <= max_rate");
  const bool use_camera_info = readRosOption<bool>(pnh_, "use_camera_info", true, "true or false");
  const bool publish_tf = readRosOption<bool>(pnh_, "publish_tf", false, "true or false");
  track_ = readRosOption<bool>(pnh_, "track", false, "true or false");
  odom_frame_ = readRosOption<std::string>(pnh_, "odom_frame", "", "a TF frame name, or empty for none");
  odom_timeout_ = readRosOption<double>(pnh_, "odom_timeout", 0.05, "a number of seconds in [0, 1]");
  if (!(odom_timeout_ >= 0.0 && odom_timeout_ <= 1.0))
    throw ParamError("odom_timeout",
                     std::to_string(odom_timeout_) + " is out of range; allowed: seconds in [0, 1] (config/node.yaml)");
  if (!odom_frame_.empty() && !track_)
    ROS_WARN("spool_detector: odom_frame '%s' is unused: only the tracker (track:=true) takes the camera's motion",
             odom_frame_.c_str());
  target_hint_radius_ = readRosOption<double>(pnh_, "target_hint_radius", 0.15, "a number of metres in (0, 1]");
  if (!(target_hint_radius_ > 0.0 && target_hint_radius_ <= 1.0))
    throw ParamError("target_hint_radius", std::to_string(target_hint_radius_) +
                                               " is out of range; allowed: metres in (0, 1] (config/node.yaml)");
  if (track_)
  {
    // TF for odom_frame's camera motion and for target hints in another frame than the camera's.
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    // Its own spinner thread: the image callback may wait for a transform while it runs.
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
  }
  // A word or a bool: roslaunch's <param value="false"> and YAML's false arrive as bools.
  bool rectified_flag = false;
  const std::string rectified = pnh_.getParam("rectified", rectified_flag)
                                    ? (rectified_flag ? "true" : "false")
                                    : readRosOption<std::string>(pnh_, "rectified", "auto", "auto, true or false");
  // A topic named .../compressed is the compressed stream of the image topic before it.
  const std::string image = nh_.resolveName("image");
  const bool compressed = transport == kCompressed || endsWith(image, kCompressedSuffix);
  const std::string base =
      endsWith(image, kCompressedSuffix) ? image.substr(0, image.size() - kCompressedSuffix.size()) : image;
  rectified_ = isRectifiedStream(rectified, base);
  spool_frame_ = readRosOption<std::string>(pnh_, "spool_frame", "spool", "a TF frame name");
  if (spool_frame_.empty())
    throw ParamError("spool_frame", "must not be empty; allowed: a TF frame name such as spool");

  startReconfigureServer();
  startDiagnostics();

  pose_pub_ = nh_.advertise<SpoolPose>("spool_pose", 10);
  pose_stamped_pub_ = pnh_.advertise<geometry_msgs::PoseStamped>("pose", 10);
  if (track_)
  {
    pose_covariance_pub_ = pnh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose_with_covariance", 10);
    hint_sub_ = nh_.subscribe("target_hint", 1, &SpoolDetectorRos::hintCallback, this);
  }
  marker_pub_ = pnh_.advertise<visualization_msgs::Marker>("marker", 10);
  debug_pub_ = private_it_.advertise("debug_image", 1);
  if (publish_tf)
    tf_broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  // camera_info beside the image topic, as image_transport names it.
  if (use_camera_info)
    info_topic_ = image_transport::getCameraInfoTopic(base);
  else
    camera_problem_ = "use_camera_info is false";
  const std::string inputs = (compressed ? subscribeCompressed(base + kCompressedSuffix, queue_size)
                                         : subscribeImages(transport, queue_size)) +
                             (use_camera_info ? " with " + info_topic_ : ", no camera_info");
  if (use_camera_info)
    camera_info_check_timer_ = nh_.createWallTimer(ros::WallDuration(kCameraInfoCheckPeriod),
                                                   [this](const ros::WallTimerEvent&) { checkCameraInfoPublished(); });
  const std::string tf = publish_tf ? " and TF frame " + spool_frame_ : "";
  ROS_INFO("spool_detector: listening on %s, publishing %s, %s and %s%s", inputs.c_str(), pose_pub_.getTopic().c_str(),
           pose_stamped_pub_.getTopic().c_str(), marker_pub_.getTopic().c_str(), tf.c_str());
}

void SpoolDetectorRos::startReconfigureServer()
{
  // The dynamic_reconfigure server starts from the parameter server: give it the values in
  // force (YAML on top of the defaults) so that it neither resets nor clamps anything.
  for (const auto& description : SpoolDetectorConfig::__getParamDescriptions__())
  {
    const ParamSpec* spec = findParamSpec(description->name);
    if (!spec)
      throw std::logic_error("cfg/SpoolDetector.cfg key '" + description->name + "' is not a detector key");
    setRosParam(pnh_, spec->key, spec->get(detector().params()));
  }
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<SpoolDetectorConfig>>(pnh_);
  reconfigure_server_->setCallback([this](SpoolDetectorConfig& config, uint32_t level)
                                   { reconfigureCallback(config, level); });
}

void SpoolDetectorRos::startDiagnostics()
{
  if (!(updater_.getPeriod() > 0.0))
    throw ParamError("diagnostic_period", "must be a positive number of seconds");
  updater_.setHardwareID("spool_vision");
  // A restarted rate window counts from half an update period on.
  stream_monitor_ = std::make_unique<StreamMonitor>(
      &min_rate_, &max_rate_, diagnostic_updater::TimeStampStatusParam(kMinFrameAge, kMaxFrameAge),
      updater_.getPeriod() / 2.0);
  updater_.add("Frame rate", stream_monitor_.get(), &StreamMonitor::diagnoseRate);
  updater_.add("Frame age", stream_monitor_.get(), &StreamMonitor::diagnoseAge);
  updater_.add("Processing", this, &SpoolDetectorRos::diagnoseProcessing);
  // Wall time: diagnostics keep coming while a replayed clock is paused.
  diagnostics_timer_ = nh_.createWallTimer(ros::WallDuration(updater_.getPeriod()),
                                           [this](const ros::WallTimerEvent&) { updater_.force_update(); });
}

std::string SpoolDetectorRos::subscribeImages(const std::string& transport, int queue_size)
{
  // The pairing exists before the first image can come (a nodelet's queue runs during onInit).
  if (!info_topic_.empty())
    subscribeInfo(queue_size, image_pairing_, &SpoolDetectorRos::imageCallback);
  try
  {
    // Hints read ~image_transport (already checked above) rather than a global parameter.
    const image_transport::TransportHints hints(transport, ros::TransportHints(), pnh_);
    image_sub_ = it_.subscribe(
        "image", queue_size,
        [this](const sensor_msgs::ImageConstPtr& msg)
        {
          if (image_pairing_)
            image_pairing_->addImage(msg);
          else
            imageCallback(msg, nullptr);
        },
        ros::VoidPtr(), hints);
  }
  catch (const image_transport::TransportLoadException& e)
  {
    throw ParamError("image_transport", "transport '" + transport + "' cannot be loaded (" + e.what() + ")");
  }
  image_topic_ = image_sub_.getTopic();
  return image_topic_ + " (" + image_sub_.getTransport() + ")";
}

std::string SpoolDetectorRos::subscribeCompressed(const std::string& topic, int queue_size)
{
  if (!info_topic_.empty())
    subscribeInfo(queue_size, compressed_pairing_, &SpoolDetectorRos::compressedCallback);
  image_topic_ = topic;
  compressed_sub_ = nh_.subscribe<sensor_msgs::CompressedImage>(topic, queue_size,
                                                                [this](const sensor_msgs::CompressedImageConstPtr& msg)
                                                                {
                                                                  if (compressed_pairing_)
                                                                    compressed_pairing_->addImage(msg);
                                                                  else
                                                                    compressedCallback(msg, nullptr);
                                                                });
  return topic + " (sensor_msgs/CompressedImage)";
}

template <typename Image>
void SpoolDetectorRos::subscribeInfo(int queue_size, std::unique_ptr<StampPairing<Image>>& pairing,
                                     void (SpoolDetectorRos::*callback)(const boost::shared_ptr<const Image>&,
                                                                        const sensor_msgs::CameraInfoConstPtr&))
{
  // Each image is processed with the camera_info of its own stamp; images without one are not.
  pairing = std::make_unique<StampPairing<Image>>(
      queue_size, [this, callback](const boost::shared_ptr<const Image>& image,
                                   const sensor_msgs::CameraInfoConstPtr& info) { (this->*callback)(image, info); });
  info_sub_ = nh_.subscribe<sensor_msgs::CameraInfo>(
      info_topic_, queue_size, [&pairing](const sensor_msgs::CameraInfoConstPtr& info) { pairing->addInfo(info); });
}

void SpoolDetectorRos::reconfigureCallback(SpoolDetectorConfig& config, uint32_t /*level*/)
{
  DetectorParams params = detector().params();
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
    tracking_.setParams(params);
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

void SpoolDetectorRos::imageCallback(const sensor_msgs::ImageConstPtr& msg, const sensor_msgs::CameraInfoConstPtr& info)
{
  char description[96];
  std::snprintf(description, sizeof(description), "image %u (%s, %ux%u)", msg->header.seq, msg->encoding.c_str(),
                msg->width, msg->height);
  handleFrame(
      msg->header, msg->encoding, [&] { return decodeImage(msg); }, info, description);
}

void SpoolDetectorRos::compressedCallback(const sensor_msgs::CompressedImageConstPtr& msg,
                                          const sensor_msgs::CameraInfoConstPtr& info)
{
  char description[96];
  std::snprintf(description, sizeof(description), "compressed image %u ('%s', %zu bytes)", msg->header.seq,
                msg->format.c_str(), msg->data.size());
  handleFrame(
      msg->header, msg->format, [&] { return decodeCompressed(*msg); }, info, description);
}

template <typename Decode>
void SpoolDetectorRos::handleFrame(const std_msgs::Header& header, const std::string& input, const Decode& decode,
                                   const sensor_msgs::CameraInfoConstPtr& info, const std::string& description)
{
  const ros::WallTime start = ros::WallTime::now();
  ++frames_since_check_;
  stream_monitor_->tick(header.stamp);
  try
  {
    const auto [image, format] = decode();
    processFrame(header, image, format, info);
  }
  catch (const std::exception& e)
  {
    // cv_bridge::Exception, cv::Exception and std::invalid_argument (bad image) all land here;
    // the controller still gets a message for the frame, with nothing detected.
    if (shouldLogError(input, e.what()))
      ROS_ERROR("spool_detector: cannot process %s: %s", description.c_str(), e.what());
    const auto& g = detector().params().geometry;
    publishPose(undefinedSpoolPose(header, (g.hole_diameter - g.puller_diameter) / 2.0));
    marker_pub_.publish(spoolMarker(header, std::nullopt, g.flange_diameter, g.hub_length));
    ++window_failed_;
  }
  const double callback_ms = (ros::WallTime::now() - start).toSec() * 1000.0;
  window_callback_ms_ += callback_ms;
  window_processing_ms_.add(callback_ms);
}

void SpoolDetectorRos::publishPose(const SpoolPose& pose)
{
  pose_pub_.publish(pose);
  // When the stamps or the clock go back (a bag's loop: the two jump at different moments) a
  // frame's now - stamp says nothing about this node's delay: as Frame age does, the period in
  // which that happens reports no latency. A stamp after the clock (a camera on another clock)
  // is left out too.
  const ros::Time now = ros::Time::now();
  if (!last_pose_stamp_.isZero() && (pose.header.stamp < last_pose_stamp_ || now < last_pose_clock_))
    latency_time_jumped_ = true;
  last_pose_stamp_ = pose.header.stamp;
  last_pose_clock_ = now;
  const double latency_ms = (now - pose.header.stamp).toSec() * 1000.0;
  if (!latency_time_jumped_ && latency_ms >= 0.0)
    window_latency_ms_.add(latency_ms);
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

std::pair<cv::Mat, PixelFormat> SpoolDetectorRos::decodeImage(const sensor_msgs::ImageConstPtr& msg)
{
  checkBuffer(*msg);
  const int rows = static_cast<int>(msg->height);
  const int cols = static_cast<int>(msg->width);
  auto* data = const_cast<uint8_t*>(msg->data.data());  // read only: wrapped, never written
  if (msg->encoding == kYuyv || msg->encoding == enc::YUV422)
  {
    const cv::Mat packed(rows, cols, CV_8UC2, data, msg->step);
    cv::cvtColor(packed, converted_, msg->encoding == kYuyv ? cv::COLOR_YUV2GRAY_YUY2 : cv::COLOR_YUV2GRAY_UYVY);
    return {converted_, PixelFormat::kMono8};
  }
  if (msg->encoding == enc::MONO16 && msg->is_bigendian)
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
    return {converted_, PixelFormat::kMono16};
  }
  // The shared frame wraps msg's buffer, which the caller holds for the whole callback.
  if (const auto direct = pixelFormatOf(msg->encoding))
    return {cv_bridge::toCvShare(msg)->image, *direct};
  // Bayer (all four patterns) and 16-bit colour are converted (the Mat owns that copy);
  // encodings without a colour meaning (depth, float) make cv_bridge throw.
  return {cv_bridge::toCvShare(msg, enc::MONO8)->image, PixelFormat::kMono8};
}

std::pair<cv::Mat, PixelFormat> SpoolDetectorRos::decodeCompressed(const sensor_msgs::CompressedImage& msg)
{
  if (msg.data.empty())
    throw std::invalid_argument("no compressed data");
  // Grey (and 16 bits where a png has them) is all the detector reads; a jpeg decoder skips
  // the colour conversion for it. The buffer is reused while the frame size stays.
  markStale(decoded_);
  cv::imdecode(msg.data, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH, &decoded_);
  if (isStale(decoded_))
    throw std::invalid_argument("cannot decode the data as jpeg or png (format '" + msg.format + "')");
  if (decoded_.depth() == CV_8U)
    return {decoded_, PixelFormat::kMono8};
  if (decoded_.depth() == CV_16U)
    return {decoded_, PixelFormat::kMono16};
  throw std::invalid_argument("decoded image has an unsupported depth (format '" + msg.format + "')");
}

void SpoolDetectorRos::hintCallback(const geometry_msgs::PointStampedConstPtr& msg)
{
  const std::lock_guard<std::mutex> lock(hint_mutex_);
  const geometry_msgs::Point& p = msg->point;
  if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
    hint_ = *msg;
  else
    hint_.reset();  // a NaN point withdraws the hint
}

std::optional<TargetHint> SpoolDetectorRos::targetHint(const std_msgs::Header& header)
{
  std::optional<geometry_msgs::PointStamped> hint;
  {
    const std::lock_guard<std::mutex> lock(hint_mutex_);
    hint = hint_;
  }
  if (!hint)
    return std::nullopt;
  const geometry_msgs::Point& p = hint->point;
  if (hint->header.frame_id.empty() || hint->header.frame_id == header.frame_id)
    return TargetHint{{p.x, p.y, p.z}, target_hint_radius_};
  // The hint's frame is fixed in the world (map, odom): where its point is seen from the camera
  // at this frame's stamp.
  const std::optional<CameraMotion> to_camera = waitForTransform(
      [&] { return tf_buffer_->lookupTransform(header.frame_id, hint->header.frame_id, header.stamp).transform; },
      "target_hint " + hint->header.frame_id,
      "no target hint in the camera frame for this frame (" + hint->header.frame_id + " to " + header.frame_id +
          "); the whole frame is searched. Check that TF joins the two frames",
      window_no_hint_);
  if (!to_camera)
    return std::nullopt;
  const cv::Vec3d at = to_camera->rotation * cv::Vec3d(p.x, p.y, p.z) + to_camera->translation;
  return TargetHint{{at[0], at[1], at[2]}, target_hint_radius_};
}

template <typename Lookup>
std::optional<CameraMotion> SpoolDetectorRos::waitForTransform(const Lookup& lookup, const std::string& kind,
                                                               const std::string& warning, int& failures)
{
  // A wall-clock wait: on sim time the clock may stand still until this frame is answered.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(odom_timeout_);
  while (true)
  {
    try
    {
      return toCameraMotion(lookup());
    }
    catch (const tf2::TransformException& e)
    {
      if (ros::WallTime::now() >= deadline)
      {
        ++failures;
        // Throttled on the wall clock, per kind, as input errors are: ROS_WARN_THROTTLE stays
        // silent for its first period of sim time, which can be all of a short bag.
        if (shouldLogError(kind, e.what()))
          ROS_WARN("spool_detector: %s: %s", warning.c_str(), e.what());
        return std::nullopt;
      }
    }
    ros::WallDuration(0.001).sleep();
  }
}

std::optional<CameraMotion> SpoolDetectorRos::cameraMotion(const std_msgs::Header& header)
{
  if (!tf_buffer_ || odom_frame_.empty())
    return std::nullopt;
  const std::optional<ros::Time> before = last_motion_stamp_;
  last_motion_stamp_ = header.stamp;
  if (!before || header.stamp <= *before)
    return std::nullopt;  // the first frame, or a bag played again (the tracker restarts)
  char range[64];
  std::snprintf(range, sizeof(range), "from %.3f to %.3f s", before->toSec(), header.stamp.toSec());
  return waitForTransform(
      [&] {
        return tf_buffer_->lookupTransform(header.frame_id, header.stamp, header.frame_id, *before, odom_frame_)
            .transform;
      },
      "odom_frame " + odom_frame_,
      "no camera motion from TF for this frame (" + header.frame_id + " " + range + " through odom_frame " +
          odom_frame_ +
          "). The tracker predicts without odometry; check that odometry's TF reaches the camera frame, "
          "or raise odom_timeout",
      window_no_motion_);
}

void SpoolDetectorRos::processFrame(const std_msgs::Header& header, const cv::Mat& image, PixelFormat format,
                                    const sensor_msgs::CameraInfoConstPtr& info)
{
  updateCamera(info, image.cols, image.rows);
  TrackedFrame frame;
  if (track_)
    frame = tracking_.process(image, format, header.stamp.toSec(), cameraMotion(header), targetHint(header));
  else
    frame.raw = frame.published = detector().detect(image, format);
  const SpoolDetection& detection = frame.published;
  reportCameraSource(image.size());
  SpoolPose pose = toSpoolPose(detection, header);
  setTrackFields(pose, track_ ? &frame : nullptr);
  publishPose(pose);
  publishSpool3d(detection, header, track_ ? &frame : nullptr);

  ++window_frames_;
  window_detected_ += detection.detected ? 1 : 0;
  window_rejected_ += frame.track.rejected_now ? 1 : 0;
  window_detector_ms_ += frame.raw.time_ms;
  window_detector_max_ms_ = std::max(window_detector_max_ms_, frame.raw.time_ms);

  if (debug_pub_.getNumSubscribers() > 0)
    debug_pub_.publish(cv_bridge::CvImage(header, enc::BGR8, renderOverlay(image, format, detection)).toImageMsg());
}

void SpoolDetectorRos::updateCamera(const sensor_msgs::CameraInfoConstPtr& info, int width, int height)
{
  // A camera publishes the same calibration with every frame: convert it only when it changes.
  if (!info || (cv::Size(width, height) == last_image_size_ &&
                (info == last_info_ || (last_info_ && sameCalibration(*info, *last_info_)))))
    return;
  last_info_ = info;
  last_image_size_ = cv::Size(width, height);
  const CameraInfoConversion conversion = cameraFromInfo(*info, width, height, rectified_);
  if (!conversion.camera)
  {
    if (info_camera_)
      detector().clearCamera();
    info_camera_.reset();
    camera_problem_ = info_topic_ + ": " + conversion.problem;
    camera_refused_ = conversion.refused;
    return;
  }
  if (!conversion.scaled.empty() && conversion.scaled != reported_scaling_)
    ROS_WARN("spool_detector: %s", conversion.scaled.c_str());
  reported_scaling_ = conversion.scaled;
  if (!conversion.distortion_ignored.empty() && conversion.distortion_ignored != reported_distortion_ignored_)
    ROS_WARN("spool_detector: %s: %s", image_topic_.c_str(), conversion.distortion_ignored.c_str());
  reported_distortion_ignored_ = conversion.distortion_ignored;
  if (info_camera_ != conversion.camera)
  {
    detector().setCamera(*conversion.camera);
    tracking_.tracker().reset();  // a track's window and error model belong to the old camera
    info_camera_ = conversion.camera;
  }
  camera_problem_.clear();
}

void SpoolDetectorRos::publishSpool3d(const SpoolDetection& detection, const std_msgs::Header& header,
                                      const TrackedFrame* frame)
{
  if (frame)
    if (const auto with_covariance = poseWithCovariance(*frame, header))
      pose_covariance_pub_.publish(*with_covariance);
  const std::optional<geometry_msgs::Pose> pose = spoolPose3d(detection);
  const auto& g = detector().params().geometry;
  marker_pub_.publish(spoolMarker(header, pose, g.flange_diameter, g.hub_length));
  if (!pose)
    return;
  geometry_msgs::PoseStamped stamped;
  stamped.header = header;
  stamped.pose = *pose;
  pose_stamped_pub_.publish(stamped);
  if (!tf_broadcaster_)
    return;
  if (header.frame_id.empty())
  {
    // TF needs a parent frame; the pose and marker carry the same empty frame_id regardless.
    if (!frame_id_missing_reported_)
      ROS_WARN(
          "spool_detector: the images have no frame_id, so no TF frame %s can be published; set the camera "
          "driver's frame_id (e.g. camera_optical_frame)",
          spool_frame_.c_str());
    frame_id_missing_reported_ = true;
    return;
  }
  geometry_msgs::TransformStamped transform;
  transform.header = header;
  transform.child_frame_id = spool_frame_;
  transform.transform.translation.x = pose->position.x;
  transform.transform.translation.y = pose->position.y;
  transform.transform.translation.z = pose->position.z;
  transform.transform.rotation = pose->orientation;
  tf_broadcaster_->sendTransform(transform);
}

void SpoolDetectorRos::reportCameraSource(const cv::Size& size)
{
  if (!detector().usingFallbackCamera())
  {
    if (!reported_problem_.empty())
      ROS_INFO("spool_detector: using the camera_info intrinsics (fx %.1f, fy %.1f px)", info_camera_->fx,
               info_camera_->fy);
    reported_problem_.clear();
    return;
  }
  if (camera_problem_ == reported_problem_)
    return;
  char camera[96];
  std::snprintf(camera, sizeof(camera), "f = %.1f px for %dx%d",
                detector().params().geometry.fallback_focal_length * size.height / 120.0, size.width, size.height);
  const std::string fallback = camera_problem_ + "; falling back to the thesis camera (" + camera +
                               ", principal point at the image centre). Distances and angles are only as good as "
                               "that guess: calibrate the camera.";
  if (camera_refused_)
    ROS_ERROR("spool_detector: %s", fallback.c_str());
  else
    ROS_WARN("spool_detector: %s", fallback.c_str());
  reported_problem_ = camera_problem_;
}

void SpoolDetectorRos::checkCameraInfoPublished()
{
  const bool idle = frames_since_check_ == 0;
  frames_since_check_ = 0;
  if (!idle || missing_info_reported_ || imagePublishers() == 0)
    return;
  ros::master::V_TopicInfo topics;
  if (!ros::master::getTopics(topics))
    return;
  if (std::any_of(topics.begin(), topics.end(), [&](const ros::master::TopicInfo& t) { return t.name == info_topic_; }))
    return;
  ROS_WARN(
      "spool_detector: %s is published but %s is not, and images are processed only with the camera_info of "
      "their stamp: nothing is measured. Publish the camera's camera_info, or set ~use_camera_info false to "
      "measure images alone with the thesis camera",
      image_topic_.c_str(), info_topic_.c_str());
  missing_info_reported_ = true;
}

uint32_t SpoolDetectorRos::imagePublishers() const
{
  return compressed_sub_ ? compressed_sub_.getNumPublishers() : image_sub_.getNumPublishers();
}

namespace
{
// "<name> p50 (ms)", "p95" and "max" of `window`.
void addQuantiles(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& name, SampleWindow& window)
{
  status.addf(name + " p50 (ms)", "%.2f", window.quantile(0.5));
  status.addf(name + " p95 (ms)", "%.2f", window.quantile(0.95));
  status.addf(name + " max (ms)", "%.2f", window.quantile(1.0));
}
}  // namespace

void SpoolDetectorRos::diagnoseProcessing(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  using diagnostic_msgs::DiagnosticStatus;
  if (window_failed_ > 0)
    status.summaryf(DiagnosticStatus::WARN, "%d frames could not be processed", window_failed_);
  else if (detector().usingFallbackCamera() && window_frames_ > 0)
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
  {
    status.addf("Callback time mean (ms)", "%.2f", window_callback_ms_ / callbacks);
    addQuantiles(status, "Processing time", window_processing_ms_);
  }
  // Image stamp to SpoolPose publication (transport, decoding, detection), in ros::Time.
  if (!window_latency_ms_.empty() && !latency_time_jumped_)
    addQuantiles(status, "Latency", window_latency_ms_);
  status.add("Camera", detector().usingFallbackCamera() ? "thesis fallback" : "camera_info");
  if (track_)
  {
    const TrackedSpool& track = tracking_.tracker().current();
    status.add("Track state", toString(track.state));
    status.add("Track age (frames)", track.age);
    status.add("Refused detections", window_rejected_);
    if (!odom_frame_.empty())
      status.add("Frames without camera motion", window_no_motion_);
    {
      const std::lock_guard<std::mutex> lock(hint_mutex_);
      status.add("Target hint", hint_ ? "given in " + hint_->header.frame_id : std::string("none"));
    }
    status.add("Frames without the target hint from TF", window_no_hint_);
  }
  window_no_motion_ = window_no_hint_ = 0;

  window_frames_ = window_detected_ = window_failed_ = window_rejected_ = 0;
  window_detector_ms_ = window_detector_max_ms_ = window_callback_ms_ = 0.0;
  window_latency_ms_.clear();
  window_processing_ms_.clear();
  latency_time_jumped_ = false;
}

}  // namespace spool_vision
