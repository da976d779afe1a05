// spool_approach_controller: ApproachController (src/control/) as a ROS node, an example for
// integrators of how a robot can be driven on what spool_detector publishes. Not part of the
// detector.
//
// Action server `approach_and_insert` (spool_vision/ApproachAndInsert): while a goal is active,
// each SpoolPose (`spool_pose`, best with ~track:=true) gives one command: `cmd_vel`
// (geometry_msgs/Twist, REP 103: linear.x forward, angular.z positive = left), `lift_velocity`
// (std_msgs/Float64, m/s, positive up) and, when `aligned` comes, `insert` (std_msgs/Empty: push the
// puller straight in). The robot's `odom` (nav_msgs/Odometry) holds the bore axis between frames:
// each pose is paired with the odometry of its own stamp (interpolated, as a TF lookup at the
// image's stamp would be), and a pose newer than every odometry waits for the next one, so the
// order in which the two topics arrive does not change the command. Without odom the node
// dead-reckons its own commands (warned once).
#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include <actionlib/server/simple_action_server.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/Empty.h>
#include <std_msgs/Float64.h>
#include <tf2/utils.h>

#include "spool_vision/ApproachAndInsertAction.h"
#include "spool_vision/SpoolPose.h"
#include "spool_vision/control/approach_controller.h"

namespace
{
namespace sv = spool_vision;
using Server = actionlib::SimpleActionServer<spool_vision::ApproachAndInsertAction>;

/// The controller's parameters from the private namespace (defaults: ApproachControllerParams).
sv::ApproachControllerParams readParams(const ros::NodeHandle& pnh, sv::GeometryParams& geometry)
{
  sv::ApproachControllerParams p;
  pnh.param("standoff_depth", p.standoff_depth, p.standoff_depth);
  pnh.param("stop_tolerance", p.stop_tolerance, p.stop_tolerance);
  pnh.param("max_speed", p.max_speed, p.max_speed);
  pnh.param("min_speed", p.min_speed, p.min_speed);
  pnh.param("slow_down", p.slow_down, p.slow_down);
  pnh.param("lookahead", p.lookahead, p.lookahead);
  pnh.param("heading_gain", p.heading_gain, p.heading_gain);
  pnh.param("max_yaw_rate", p.max_yaw_rate, p.max_yaw_rate);
  pnh.param("max_bore_bearing", p.max_bore_bearing, p.max_bore_bearing);
  pnh.param("line_memory", p.line_memory, p.line_memory);
  pnh.param("max_line_jump", p.max_line_jump, p.max_line_jump);
  pnh.param("max_disagreements", p.max_disagreements, p.max_disagreements);
  pnh.param("lift_gain", p.lift_gain, p.lift_gain);
  pnh.param("max_lift_rate", p.max_lift_rate, p.max_lift_rate);
  pnh.param("hold_timeout", p.hold_timeout, p.hold_timeout);
  pnh.param("lost_timeout", p.lost_timeout, p.lost_timeout);
  pnh.param("backoff_distance", p.backoff_distance, p.backoff_distance);
  pnh.param("backoff_speed", p.backoff_speed, p.backoff_speed);
  pnh.param("max_retries", p.max_retries, p.max_retries);
  pnh.param("puller_offset_x", geometry.puller_offset_x, geometry.puller_offset_x);
  pnh.param("puller_offset_y", geometry.puller_offset_y, geometry.puller_offset_y);
  return p;
}

class ApproachControllerNode
{
public:
  ApproachControllerNode(ros::NodeHandle& nh, ros::NodeHandle& pnh)
    : params_(readParams(pnh, geometry_)), server_(nh, "approach_and_insert", false)
  {
    sv::ApproachController check(params_, geometry_);  // throws naming a bad key before anything runs
    cmd_vel_ = nh.advertise<geometry_msgs::Twist>("cmd_vel", 1);
    lift_ = nh.advertise<std_msgs::Float64>("lift_velocity", 1);
    insert_ = nh.advertise<std_msgs::Empty>("insert", 1, true);
    pose_sub_ = nh.subscribe("spool_pose", 1, &ApproachControllerNode::onPose, this);
    odom_sub_ = nh.subscribe("odom", 1, &ApproachControllerNode::onOdometry, this);
    server_.registerGoalCallback([this] { onGoal(); });
    server_.registerPreemptCallback([this] { onPreempt(); });
    server_.start();
  }

private:
  void onGoal()
  {
    server_.acceptNewGoal();
    controller_.emplace(params_, geometry_);
    last_stamp_.reset();
    start_stamp_.reset();
    pending_.reset();
    dead_reckoning_ = sv::OdometryPose();
  }

  void onPreempt()
  {
    stop();
    server_.setPreempted(result("preempted"));
  }

  void onOdometry(const nav_msgs::Odometry& odom)
  {
    // ROS's odom (x forward, y left, yaw counter-clockwise) as the controller's floor frame
    // (z forward, x right, heading clockwise): only the motion between frames matters.
    const ros::Time stamp = odom.header.stamp;
    if (!odometry_.empty() && stamp < odometry_.back().first)
      odometry_.clear();  // time went back (a bag looped, a simulation restarted)
    odometry_.emplace_back(stamp, sv::OdometryPose{-odom.pose.pose.position.y, odom.pose.pose.position.x,
                                                   -tf2::getYaw(odom.pose.pose.orientation)});
    while (odometry_.size() > 2 && (stamp - odometry_.front().first).toSec() > kOdometryHistory)
      odometry_.pop_front();
    if (pending_ && stamp >= pending_->header.stamp)
      processPending();
  }

  void onPose(const spool_vision::SpoolPose& pose)
  {
    if (!server_.isActive() || !controller_)
      return;
    if (pending_)
      processPending();  // its odometry never came: it goes with the newest there is
    // A pose newer than every odometry (the odometry of its stamp still on its way) waits for it.
    if (!odometry_.empty() && pose.header.stamp > odometry_.back().first &&
        (pose.header.stamp - odometry_.back().first).toSec() < kOdometryMaxAge)
    {
      pending_ = pose;
      return;
    }
    process(pose);
  }

  void processPending()
  {
    const spool_vision::SpoolPose pose = *pending_;
    pending_.reset();
    if (server_.isActive() && controller_)
      process(pose);
  }

  /// The odometry at `stamp`, interpolated between the two around it (the nearest outside them);
  /// false when none is within kOdometryMaxAge.
  bool odometryAt(const ros::Time& stamp, sv::OdometryPose& pose) const
  {
    if (odometry_.empty())
      return false;
    auto after = std::lower_bound(odometry_.begin(), odometry_.end(), stamp,
                                  [](const auto& sample, const ros::Time& t) { return sample.first < t; });
    if (after == odometry_.begin() || after == odometry_.end())
    {
      const auto& nearest = after == odometry_.end() ? odometry_.back() : odometry_.front();
      pose = nearest.second;
      return std::abs((stamp - nearest.first).toSec()) < kOdometryMaxAge;
    }
    const auto& before = *std::prev(after);
    const double span = (after->first - before.first).toSec();
    const double w = span > 0.0 ? (stamp - before.first).toSec() / span : 1.0;
    pose.x = before.second.x + w * (after->second.x - before.second.x);
    pose.z = before.second.z + w * (after->second.z - before.second.z);
    pose.heading = before.second.heading + w * (after->second.heading - before.second.heading);
    return true;
  }

  void process(const spool_vision::SpoolPose& pose)
  {
    const ros::Time stamp = pose.header.stamp;
    if (!start_stamp_)
      start_stamp_ = stamp;
    // A stamp that does not advance (a bag looped, a repeated message) gets a nominal period.
    const double dt = last_stamp_ && stamp > *last_stamp_ ? std::min((stamp - *last_stamp_).toSec(), 1.0) : 0.1;
    last_stamp_ = stamp;
    sv::OdometryPose odometry;
    if (!odometryAt(stamp, odometry))
    {
      ROS_WARN_ONCE("spool_approach_controller: no odom within 0.5 s of the poses; dead-reckoning the commands");
      advanceDeadReckoning(dt);
      odometry = dead_reckoning_;
    }

    sv::ApproachObservation o;
    o.detected = pose.detected;
    o.coasting = pose.track_state == spool_vision::SpoolPose::TRACK_COASTING;
    o.aligned = pose.aligned;
    o.position = {pose.position.x, pose.position.y, pose.position.z};
    o.axis = {pose.axis.x, pose.axis.y, pose.axis.z};
    const sv::ApproachCommand command = controller_->update(o, odometry, dt);
    last_command_ = command;
    publish(command);

    spool_vision::ApproachAndInsertFeedback feedback;
    feedback.phase = sv::toString(controller_->phase());
    feedback.retries = static_cast<std::uint32_t>(controller_->retries());
    const double nan = std::nan("");
    feedback.lateral_error = feedback.heading_error = feedback.depth_to_go = nan;
    controller_->errors(odometry, feedback.lateral_error, feedback.heading_error, feedback.depth_to_go);
    server_.publishFeedback(feedback);

    elapsed_ = (stamp - *start_stamp_).toSec();
    if (command.insert)
    {
      insert_.publish(std_msgs::Empty());
      server_.setSucceeded(result("inserted"));
    }
    else if (controller_->phase() == sv::ApproachPhase::kGaveUp)
    {
      stop();
      server_.setAborted(result("gave_up"));
    }
  }

  void advanceDeadReckoning(double dt)
  {
    const double heading = dead_reckoning_.heading + 0.5 * last_command_.yaw_rate * dt;
    dead_reckoning_.x += last_command_.speed * dt * std::sin(heading);
    dead_reckoning_.z += last_command_.speed * dt * std::cos(heading);
    dead_reckoning_.heading += last_command_.yaw_rate * dt;
  }

  void publish(const sv::ApproachCommand& command)
  {
    geometry_msgs::Twist twist;
    twist.linear.x = command.speed;
    twist.angular.z = -command.yaw_rate;  // the controller's yaw rate turns right
    cmd_vel_.publish(twist);
    std_msgs::Float64 lift;
    lift.data = command.lift_rate;
    lift_.publish(lift);
  }

  void stop()
  {
    last_command_ = sv::ApproachCommand();
    publish(last_command_);
  }

  spool_vision::ApproachAndInsertResult result(const std::string& outcome) const
  {
    spool_vision::ApproachAndInsertResult r;
    r.outcome = outcome;
    r.retries = controller_ ? static_cast<std::uint32_t>(controller_->retries()) : 0u;
    r.time = elapsed_;
    return r;
  }

  sv::GeometryParams geometry_;
  sv::ApproachControllerParams params_;
  Server server_;
  std::optional<sv::ApproachController> controller_;
  ros::Publisher cmd_vel_, lift_, insert_;
  ros::Subscriber pose_sub_, odom_sub_;
  /// s: odometry kept for pairing; and the largest gap between a pose and its odometry
  static constexpr double kOdometryHistory = 2.0;
  static constexpr double kOdometryMaxAge = 0.5;
  std::deque<std::pair<ros::Time, sv::OdometryPose>> odometry_;
  std::optional<spool_vision::SpoolPose> pending_;
  sv::OdometryPose dead_reckoning_;
  sv::ApproachCommand last_command_;
  std::optional<ros::Time> last_stamp_, start_stamp_;
  double elapsed_ = 0.0;
};
}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "spool_approach_controller");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try
  {
    ApproachControllerNode node(nh, pnh);
    ros::spin();
  }
  catch (const std::invalid_argument& e)
  {
    ROS_FATAL(
        "spool_approach_controller: %s (set it under ~ in the launch file; see "
        "config/approach_controller.yaml)",
        e.what());
    return 1;
  }
  return 0;
}
