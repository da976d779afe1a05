// The ROS adapter: image + camera_info in; spool_vision/SpoolPose, the spool's 3D pose (PoseStamped,
// optionally TF), an RViz marker and a debug overlay out. One class behind both the
// `spool_detector` node and the SpoolDetectorNodelet.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>

#include <diagnostic_updater/diagnostic_updater.h>
#include <diagnostic_updater/update_functions.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PointStamped.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "sample_window.h"
#include "spool_vision/SpoolDetectorConfig.h"
#include "spool_vision/SpoolPose.h"
#include "spool_vision/spool_detector.h"
#include "spool_vision/spool_tracker.h"
#include "stamp_pairing.h"
#include "stream_monitor.h"

namespace spool_vision
{
class SpoolDetectorRos
{
public:
  /// Reads the parameters from `pnh`, then subscribes and advertises on `nh`. Throws ParamError
  /// (a bad or unknown parameter, or an image_transport that cannot be loaded) so that the node
  /// and the nodelet refuse to start instead of running with a setting nobody asked for.
  /// Every callback runs on the handles' callback queue, one at a time (ros::spin in the node,
  /// the nodelet's single-threaded queue), which is what makes the unlocked state below safe.
  /// `name` labels the diagnostics (the node name, or the nodelet name inside a manager).
  SpoolDetectorRos(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name);

  /// Private keys that configure the node rather than the detector.
  static const std::set<std::string>& rosKeys();

private:
  /// The dynamic_reconfigure server, seeded with the values in force (YAML on the defaults).
  void startReconfigureServer();
  /// The diagnostic updater's tasks (frame rate, frame age, processing), on a wall-time timer.
  void startDiagnostics();
  /// Subscribes `image` through image_transport (raw and any installed plugin), paired with
  /// camera_info on info_topic_ unless that is empty (use_camera_info false); returns the input
  /// for the start-up line.
  std::string subscribeImages(const std::string& transport, int queue_size);
  /// The same for sensor_msgs/CompressedImage on `topic`, subscribed directly (Debian has no
  /// compressed plugin).
  std::string subscribeCompressed(const std::string& topic, int queue_size);
  /// camera_info on info_topic_, each paired with the image of its stamp.
  template <typename Image>
  void subscribeInfo(int queue_size, std::unique_ptr<StampPairing<Image>>& pairing,
                     void (SpoolDetectorRos::*callback)(const boost::shared_ptr<const Image>&,
                                                        const sensor_msgs::CameraInfoConstPtr&));
  /// `info` is the image's camera_info (same stamp), or null with use_camera_info false.
  void imageCallback(const sensor_msgs::ImageConstPtr& msg, const sensor_msgs::CameraInfoConstPtr& info);
  void compressedCallback(const sensor_msgs::CompressedImageConstPtr& msg, const sensor_msgs::CameraInfoConstPtr& info);
  /// Runs `decode` (gives the frame and its pixel format) and the detector on one input message;
  /// a failure is logged once per kind (`input`: encoding or compressed format) and answered
  /// with an undefined SpoolPose. `description` names the message in the log.
  template <typename Decode>
  void handleFrame(const std_msgs::Header& header, const std::string& input, const Decode& decode,
                   const sensor_msgs::CameraInfoConstPtr& info, const std::string& description);
  void reconfigureCallback(SpoolDetectorConfig& config, uint32_t level);
  /// The frame of a raw image message (wrapped where possible, else converted into converted_).
  std::pair<cv::Mat, PixelFormat> decodeImage(const sensor_msgs::ImageConstPtr& msg);
  /// The frame of a jpeg or png message, decoded into decoded_ (grey: all the detector reads).
  std::pair<cv::Mat, PixelFormat> decodeCompressed(const sensor_msgs::CompressedImage& msg);
  /// With ~odom_frame: the camera's motion from the last frame's stamp to this one's, looked up in
  /// TF through odom_frame (waiting up to ~odom_timeout wall seconds for it); nullopt on the first
  /// frame, after a time jump, or when TF has no transform (logged, counted in the diagnostics).
  std::optional<CameraMotion> cameraMotion(const std_msgs::Header& header);
  /// The latest ~target_hint (geometry_msgs/PointStamped; a NaN point withdraws it).
  void hintCallback(const geometry_msgs::PointStampedConstPtr& msg);
  /// The latest target hint in the camera frame at this frame's stamp (its point as it is when
  /// given in the camera's frame or none, else through TF), with ~target_hint_radius; nullopt
  /// without a hint or when TF has no transform (logged, counted in the diagnostics).
  std::optional<TargetHint> targetHint(const std_msgs::Header& header);
  /// `lookup`'s transform as a CameraMotion, retried until ~odom_timeout wall seconds pass; then
  /// nullopt, `failures` counted and `warning` logged once per throttle period of `kind`.
  template <typename Lookup>
  std::optional<CameraMotion> waitForTransform(const Lookup& lookup, const std::string& kind,
                                               const std::string& warning, int& failures);
  void processFrame(const std_msgs::Header& header, const cv::Mat& image, PixelFormat format,
                    const sensor_msgs::CameraInfoConstPtr& info);
  /// Gives the detector the camera `info` describes for an image of this size (or the fallback).
  void updateCamera(const sensor_msgs::CameraInfoConstPtr& info, int width, int height);
  /// Publishes `pose` on ~spool_pose and takes its latency (now - its stamp) into the window.
  void publishPose(const SpoolPose& pose);
  /// ~pose, the marker and TF of the published detection; ~pose_with_covariance of `frame`'s
  /// track (with track_).
  void publishSpool3d(const SpoolDetection& detection, const std_msgs::Header& header,
                      const TrackedFrame* frame = nullptr);
  /// True when an input error of this kind was not logged in the last throttle period.
  bool shouldLogError(const std::string& encoding, const std::string& what);
  void reportCameraSource(const cv::Size& size);
  /// Publishers of the image topic the node listens to (either kind of subscriber).
  uint32_t imagePublishers() const;
  /// Images published but no camera_info beside them: say once that nothing is processed and why.
  void checkCameraInfoPublished();
  void diagnoseProcessing(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  /// The detector, followed by the tracker when track_ (TrackingDetector::process).
  TrackingDetector tracking_;
  bool track_ = false;
  SpoolDetector& detector()
  {
    return tracking_.detector();
  }

  image_transport::ImageTransport it_;
  image_transport::ImageTransport private_it_;
  // Images through image_transport, or compressed images read by the node itself; with
  // use_camera_info, camera_info and the pairing of the two by stamp (one kind used).
  image_transport::Subscriber image_sub_;
  ros::Subscriber compressed_sub_;
  ros::Subscriber info_sub_;
  std::unique_ptr<StampPairing<sensor_msgs::Image>> image_pairing_;
  std::unique_ptr<StampPairing<sensor_msgs::CompressedImage>> compressed_pairing_;
  std::string image_topic_;  ///< resolved, as subscribed
  std::string info_topic_;   ///< resolved; empty with use_camera_info false
  ros::Publisher pose_pub_;
  ros::Publisher pose_stamped_pub_;
  ros::Publisher pose_covariance_pub_;  ///< with track_ only
  ros::Publisher marker_pub_;
  image_transport::Publisher debug_pub_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_broadcaster_;  ///< with publish_tf only
  std::string spool_frame_;
  std::string odom_frame_;  ///< empty: no camera motion for the tracker
  double odom_timeout_ = 0.05;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;  ///< with track_ only
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::optional<ros::Time> last_motion_stamp_;
  int window_no_motion_ = 0;
  ros::Subscriber hint_sub_;  ///< target_hint, with track_ only
  std::mutex hint_mutex_;
  std::optional<geometry_msgs::PointStamped> hint_;
  double target_hint_radius_ = 0.15;
  int window_no_hint_ = 0;
  std::optional<ros::WallTime>
      last_motion_warning_;  ///< tracked frames after the first without a camera motion from TF
  bool frame_id_missing_reported_ = false;

  std::unique_ptr<dynamic_reconfigure::Server<SpoolDetectorConfig>> reconfigure_server_;
  std::optional<SpoolDetectorConfig> applied_config_;

  double min_rate_;
  double max_rate_;
  diagnostic_updater::Updater updater_;
  std::unique_ptr<StreamMonitor> stream_monitor_;
  ros::WallTimer diagnostics_timer_;

  // Camera source: calibrated intrinsics from camera_info, or why the fallback applies.
  sensor_msgs::CameraInfoConstPtr last_info_;  ///< converted for last_image_size_
  cv::Size last_image_size_;
  std::optional<CameraIntrinsics> info_camera_;
  bool rectified_ = false;  ///< the image is rectified (P, no distortion) whatever D says
  std::string camera_problem_ = "no camera_info received yet";
  bool camera_refused_ = false;   ///< camera_problem_ is a refused calibration (an error)
  std::string reported_problem_;  ///< the fallback reason last logged; empty while calibrated
  std::string reported_scaling_;
  std::string reported_distortion_ignored_;
  ros::WallTimer camera_info_check_timer_;
  int frames_since_check_ = 0;
  bool missing_info_reported_ = false;

  // Statistics since the last diagnostics update.
  int window_frames_ = 0;
  int window_detected_ = 0;
  int window_failed_ = 0;
  std::map<std::string, ros::WallTime> last_error_log_;  ///< per kind of input error
  cv::Mat converted_;  ///< frames the adapter converts itself (YUYV/UYVY, big-endian mono16)
  cv::Mat decoded_;    ///< compressed frames, decoded into the same buffer every time
  double window_detector_ms_ = 0.0;
  double window_detector_max_ms_ = 0.0;
  double window_callback_ms_ = 0.0;
  int window_rejected_ = 0;           ///< detections the gate refused
  SampleWindow window_latency_ms_;    ///< ros::Time::now() - stamp at each SpoolPose's publication
  bool latency_time_jumped_ = false;  ///< the stamps or the clock went back in this period
  ros::Time last_pose_stamp_;
  ros::Time last_pose_clock_;
  SampleWindow window_processing_ms_;  ///< wall time of each frame's callback
};

}  // namespace spool_vision
