// spool_sim_world: spool_sim's world (ApproachWorld: a forklift with a webcam in front of a shelf,
// src/sim/) behind ROS topics, so that spool_detector and spool_approach_controller close the loop
// through their real topics. A test harness, like a Gazebo world: not part of the detector.
//
// Sim time: the node publishes /clock (run everything with /use_sim_time true) and steps in lock
// with the loop. It idles (the clock runs at wall speed, no frames) until the approach goal is
// active on `approach_status` (actionlib_msgs/GoalStatusArray, the action server's status), then
// per control period: publishes the frame its camera sees (`image_raw` + `camera_info`,
// image_transport's CameraPublisher; raw with the C270-like lens's D) and `odom`
// (nav_msgs/Odometry with the drive's errors; before the first frame, the latched `target_hint`:
// the slot as the robot's navigation knows it, in odom), waits (wall time, ~response_timeout) for the
// controller's whole answer to it (`cmd_vel`, `lift_velocity` and the action's feedback on
// `approach_feedback`: topics arrive in no fixed order, so all three are awaited), drives 1/~rate s
// on it and advances the clock. A push (the feedback's phase `insert`, or `insert`) is judged on
// the renderer's geometry at the pose it was decided on and ends the trial, as do a drive into the
// face, the goal ending (gave up) and ~max_steps. The judgement is latched on ~outcome
// (spool_vision/SimTrialOutcome). One trial per run: the detector's track is not reset.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

#include <actionlib_msgs/GoalStatusArray.h>
#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PointStamped.h>
#include <geometry_msgs/Twist.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/image_encodings.h>
#include <std_msgs/Empty.h>
#include <std_msgs/Float64.h>
#include <tf2/LinearMath/Transform.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include "camera_info_conversion.h"
#include "spool_vision/ApproachAndInsertActionFeedback.h"
#include "spool_vision/SimTrialOutcome.h"
#include "spool_vision/SpoolPose.h"
#include "spool_vision/detector_params.h"
#include "spool_vision/sim/closed_loop.h"

namespace
{
namespace sv = spool_vision;

// REP 105's frames of the robot's odometry (nav_msgs/Odometry and TF).
const char* const kOdomFrame = "odom";
const char* const kBaseFrame = "base_link";

struct SimWorldParams
{
  int seed = 1;
  int width = 640;
  int height = 480;
  double rate = 10.0;             ///< Hz, frames and control periods
  int max_steps = 300;            ///< frames before a timeout
  double response_timeout = 5.0;  ///< wall s to wait for the controller's answer to a frame
  std::string frame_id = "sim_camera_optical";
  double puller_offset_y = sv::GeometryParams{}.puller_offset_y;
  bool target_hint = true;  ///< publish the slot where the navigation puts it (target_hint, odom)
};

template <typename T>
std::string text(T value)
{
  std::ostringstream out;
  out << value;
  return out.str();
}

/// `key` from `pnh` (or `fallback`), refused outside [low, high] with a message naming the key,
/// the range and the fix.
template <typename T>
T readBounded(const ros::NodeHandle& pnh, const std::string& key, T fallback, T low, T high)
{
  const std::string range = "[" + text(low) + ", " + text(high) + "]";
  T value = fallback;
  if (pnh.hasParam(key) && !pnh.getParam(key, value))
    throw sv::ParamError(key, "has the wrong type; set a number in " + range + " (config/sim_world.yaml)");
  if (!(value >= low && value <= high))
    throw sv::ParamError(key, text(value) + " is outside " + range + "; set it in that range (config/sim_world.yaml)");
  return value;
}

SimWorldParams readParams(const ros::NodeHandle& pnh)
{
  SimWorldParams p;
  p.seed = readBounded(pnh, "seed", p.seed, 0, std::numeric_limits<int>::max());
  p.width = readBounded(pnh, "width", p.width, 64, 4096);
  p.height = readBounded(pnh, "height", p.height, 48, 4096);
  p.rate = readBounded(pnh, "rate", p.rate, 1.0, 100.0);
  p.max_steps = readBounded(pnh, "max_steps", p.max_steps, 1, 100000);
  p.response_timeout = readBounded(pnh, "response_timeout", p.response_timeout, 0.01, 600.0);
  p.puller_offset_y = readBounded(pnh, "puller_offset_y", p.puller_offset_y, -1.0, 1.0);
  pnh.param("frame_id", p.frame_id, p.frame_id);
  if (pnh.hasParam("target_hint") && !pnh.getParam("target_hint", p.target_hint))
    throw sv::ParamError("target_hint", "has the wrong type; set true or false (config/sim_world.yaml)");
  return p;
}

sv::GeometryParams geometryOf(const SimWorldParams& p)
{
  sv::GeometryParams g;
  g.puller_offset_y = p.puller_offset_y;
  return g;
}

class SimWorldNode
{
public:
  SimWorldNode(ros::NodeHandle& nh, ros::NodeHandle& pnh)
    : params_(readParams(pnh))
    , world_(static_cast<std::uint64_t>(params_.seed), cv::Size(params_.width, params_.height), geometryOf(params_),
             sv::ForkliftLimits())
    , it_(nh)
  {
    info_ = sv::infoFromCamera(world_.camera());
    clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 1);
    camera_pub_ = it_.advertiseCamera("image_raw", 1);
    odom_pub_ = nh.advertise<nav_msgs::Odometry>("odom", 1);
    // The camera is the robot's reference point: its optical frame (z forward, x right, y down)
    // sits on base_link (x forward, y left, z up), turned as REP 103 turns optical frames.
    geometry_msgs::TransformStamped mount;
    mount.header.stamp = time_;
    mount.header.frame_id = kBaseFrame;
    mount.child_frame_id = params_.frame_id;
    mount.transform.rotation.x = -0.5;
    mount.transform.rotation.y = 0.5;
    mount.transform.rotation.z = -0.5;
    mount.transform.rotation.w = 0.5;
    static_tf_.sendTransform(mount);
    outcome_pub_ = pnh.advertise<spool_vision::SimTrialOutcome>("outcome", 1, true);
    if (params_.target_hint)
      hint_pub_ = nh.advertise<geometry_msgs::PointStamped>("target_hint", 1, true);
    cmd_sub_ = nh.subscribe("cmd_vel", 10, &SimWorldNode::onCmdVel, this);
    lift_sub_ = nh.subscribe("lift_velocity", 10, &SimWorldNode::onLift, this);
    insert_sub_ = nh.subscribe("insert", 10, &SimWorldNode::onInsert, this);
    pose_sub_ = nh.subscribe("spool_pose", 10, &SimWorldNode::onPose, this);
    feedback_sub_ = nh.subscribe("approach_feedback", 10, &SimWorldNode::onFeedback, this);
    status_sub_ = nh.subscribe("approach_status", 10, &SimWorldNode::onStatus, this);
    ROS_INFO("spool_sim_world: trial seed %d at %dx%d, %.1f Hz; waiting for an active goal on %s", params_.seed,
             params_.width, params_.height, params_.rate, status_sub_.getTopic().c_str());
  }

  /// Idles, runs the trial when the goal comes, then idles until shutdown (the clock keeps going).
  void run()
  {
    idleUntil([this] { return goal_active_.load(); });
    if (!ros::ok())
      return;
    runTrial();
    idleUntil([] { return false; });
  }

private:
  template <typename Predicate>
  void idleUntil(Predicate done)
  {
    ros::WallTime last = ros::WallTime::now();
    while (ros::ok() && !done())
    {
      ros::WallDuration(0.01).sleep();
      const ros::WallTime now = ros::WallTime::now();
      advanceClock((now - last).toSec());
      last = now;
    }
  }

  void advanceClock(double seconds)
  {
    time_ += ros::Duration(seconds);
    rosgraph_msgs::Clock clock;
    clock.clock = time_;
    clock_pub_.publish(clock);
  }

  void runTrial()
  {
    const double dt = 1.0 / params_.rate;
    const ros::Time start = time_;
    spool_vision::SimTrialOutcome outcome;
    outcome.seed = static_cast<std::uint64_t>(params_.seed);
    outcome.tolerance = world_.tolerance();
    outcome.time_to_insert = outcome.front_miss = outcome.back_miss = std::numeric_limits<double>::quiet_NaN();
    outcome.outcome = sv::toString(sv::TrialOutcome::kTimeout);
    for (int step = 0; step < params_.max_steps && ros::ok(); ++step)
    {
      if (world_.droveIntoFace())
      {
        outcome.outcome = sv::toString(sv::TrialOutcome::kCollision);
        break;
      }
      sv::RenderedFrame frame;
      try
      {
        frame = world_.view(step);
      }
      catch (const std::invalid_argument&)
      {
        outcome.outcome = sv::toString(sv::TrialOutcome::kLost);
        break;
      }
      const Answers before = answers();
      if (step == 0 && params_.target_hint)
        publishTargetHint(frame);
      publishFrame(frame);
      outcome.steps = static_cast<std::uint32_t>(step + 1);
      const Answers after = awaitAnswer(before);
      if (after.inserts > before.inserts || after.pushed)
      {
        outcome.time_to_insert = (time_ - start).toSec();
        outcome.outcome = sv::toString(world_.judgePush(outcome.front_miss, outcome.back_miss));
        break;
      }
      if (goal_ended_)
      {
        outcome.outcome = sv::toString(held_ ? sv::TrialOutcome::kTimeout : sv::TrialOutcome::kLost);
        break;
      }
      world_.drive(command(), dt);
      advanceClock(dt);
    }
    outcome.header.stamp = time_;
    outcome_pub_.publish(outcome);
    ROS_INFO("spool_sim_world: seed %d: %s after %u frames (time to insert %.1f s, misses %.1f/%.1f mm, t_f %.2f mm)",
             params_.seed, outcome.outcome.c_str(), outcome.steps, outcome.time_to_insert, 1e3 * outcome.front_miss,
             1e3 * outcome.back_miss, 1e3 * outcome.tolerance);
  }

  /// The slot the robot was sent to, as its navigation knows it: the target's bore front centre,
  /// off by the trial's navigation error (TrialStart::navigation_error, as spool_sim
  /// --target-hint), fixed in odom. Latched: the detector follows only a spool there.
  void publishTargetHint(const sv::RenderedFrame& frame)
  {
    const cv::Point2d error = world_.start().navigation_error;
    const tf2::Vector3 in_camera(frame.truth.position.x + error.x, frame.truth.position.y,
                                 frame.truth.position.z + error.y);
    const tf2::Transform mount(tf2::Quaternion(-0.5, 0.5, -0.5, 0.5));  // as the static TF above
    const sv::OdometryPose& o = world_.robot().odometry();
    const tf2::Transform base(tf2::Quaternion(0.0, 0.0, std::sin(-0.5 * o.heading), std::cos(-0.5 * o.heading)),
                              tf2::Vector3(o.z, -o.x, 0.0));  // as publishFrame's odom
    const tf2::Vector3 in_odom = base * (mount * in_camera);
    geometry_msgs::PointStamped hint;
    hint.header.stamp = time_;
    hint.header.frame_id = kOdomFrame;
    hint.point.x = in_odom.x();
    hint.point.y = in_odom.y();
    hint.point.z = in_odom.z();
    hint_pub_.publish(hint);
  }

  void publishFrame(const sv::RenderedFrame& frame)
  {
    // Odometry first: the controller pairs each pose with the odometry of its stamp.
    // The controller's floor frame (x right, z forward, heading clockwise) as REP 103's odom
    // (x forward, y left, yaw counter-clockwise).
    const sv::OdometryPose& o = world_.robot().odometry();
    nav_msgs::Odometry odom;
    odom.header.stamp = time_;
    odom.header.frame_id = kOdomFrame;
    odom.child_frame_id = kBaseFrame;
    odom.pose.pose.position.x = o.z;
    odom.pose.pose.position.y = -o.x;
    odom.pose.pose.orientation.z = std::sin(-0.5 * o.heading);  // a yaw of -heading
    odom.pose.pose.orientation.w = std::cos(-0.5 * o.heading);
    odom.twist.twist.linear.x = world_.robot().state().speed;
    odom.twist.twist.angular.z = -world_.robot().state().yaw_rate;
    odom_pub_.publish(odom);
    geometry_msgs::TransformStamped base;
    base.header = odom.header;
    base.child_frame_id = kBaseFrame;
    base.transform.translation.x = odom.pose.pose.position.x;
    base.transform.translation.y = odom.pose.pose.position.y;
    base.transform.rotation = odom.pose.pose.orientation;
    tf_.sendTransform(base);
    std_msgs::Header header;
    header.stamp = time_;
    header.frame_id = params_.frame_id;
    sensor_msgs::CameraInfo info = info_;
    info.header = header;
    camera_pub_.publish(*cv_bridge::CvImage(header, sensor_msgs::image_encodings::BGR8, frame.image).toImageMsg(),
                        info);
  }

  struct Answers
  {
    unsigned commands = 0, lifts = 0, feedbacks = 0, inserts = 0;
    bool pushed = false;  ///< the last feedback's phase is `insert`
  };

  Answers answers()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return answers_;
  }

  /// Waits until the controller answered the frame (a cmd_vel, a lift_velocity and a feedback,
  /// or an insert) or the goal ended; after ~response_timeout (wall) the robot stands still for the period.
  Answers awaitAnswer(const Answers& before)
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const bool answered =
        answered_.wait_for(lock, std::chrono::duration<double>(params_.response_timeout),
                           [&]
                           {
                             return (answers_.commands > before.commands && answers_.lifts > before.lifts &&
                                     answers_.feedbacks > before.feedbacks) ||
                                    answers_.inserts > before.inserts || goal_ended_ || !ros::ok();
                           });
    if (!answered)
    {
      ROS_WARN_THROTTLE(
          5.0,
          "spool_sim_world: no cmd_vel, lift_velocity and feedback within %.1f s (wall) of a frame; the robot "
          "stands still for this period (is the detector or the controller running?)",
          params_.response_timeout);
      command_ = sv::ApproachCommand();
    }
    return answers_;
  }

  sv::ApproachCommand command()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return command_;
  }

  void onCmdVel(const geometry_msgs::Twist& twist)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    command_.speed = twist.linear.x;
    command_.yaw_rate = -twist.angular.z;  // REP 103 turns left; the forklift's yaw rate turns right
    ++answers_.commands;
    answered_.notify_all();
  }

  void onLift(const std_msgs::Float64& lift)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    command_.lift_rate = lift.data;
    ++answers_.lifts;
    answered_.notify_all();
  }

  void onInsert(const std_msgs::Empty&)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++answers_.inserts;
    answered_.notify_all();
  }

  void onFeedback(const spool_vision::ApproachAndInsertActionFeedback& feedback)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    answers_.pushed = feedback.feedback.phase == sv::toString(sv::ApproachPhase::kInsert);
    ++answers_.feedbacks;
    answered_.notify_all();
  }

  void onPose(const spool_vision::SpoolPose& pose)
  {
    held_ = pose.detected;
  }

  void onStatus(const actionlib_msgs::GoalStatusArray& status)
  {
    bool active = false;
    bool ended = false;
    for (const actionlib_msgs::GoalStatus& goal : status.status_list)
    {
      active = active || goal.status == actionlib_msgs::GoalStatus::ACTIVE;
      ended = ended || goal.status == actionlib_msgs::GoalStatus::ABORTED ||
              goal.status == actionlib_msgs::GoalStatus::PREEMPTED;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (active)
      goal_active_ = true;
    if (goal_active_ && ended && !active)
    {
      goal_ended_ = true;
      answered_.notify_all();
    }
  }

  SimWorldParams params_;
  sv::ApproachWorld world_;
  image_transport::ImageTransport it_;
  sensor_msgs::CameraInfo info_;
  ros::Publisher clock_pub_, odom_pub_, outcome_pub_, hint_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  image_transport::CameraPublisher camera_pub_;
  ros::Subscriber cmd_sub_, lift_sub_, insert_sub_, pose_sub_, feedback_sub_, status_sub_;
  ros::Time time_{1.0};  // sim time starts at 1 s: 0 is "no time yet" to ROS

  std::mutex mutex_;
  std::condition_variable answered_;
  Answers answers_;
  sv::ApproachCommand command_;
  std::atomic<bool> goal_active_{false}, goal_ended_{false}, held_{false};
};
}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "spool_sim_world");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try
  {
    SimWorldNode node(nh, pnh);
    ros::AsyncSpinner spinner(2);
    spinner.start();
    node.run();
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("spool_sim_world: %s", e.what());
    return 1;
  }
  return 0;
}
