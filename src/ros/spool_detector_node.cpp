// The spool detector as a stand-alone node (the same class as SpoolDetectorNodelet).
#include <memory>

#include <ros/ros.h>

#include "ros_params.h"
#include "spool_detector_ros.h"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "spool_detector");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::unique_ptr<spool_vision::SpoolDetectorRos> detector;
  try
  {
    detector = std::make_unique<spool_vision::SpoolDetectorRos>(nh, pnh, ros::this_node::getName());
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("%s: refusing to start: %s", ros::this_node::getName().c_str(),
              spool_vision::refusalMessage(ros::this_node::getName(), e).c_str());
    return 1;
  }
  ros::spin();
  return 0;
}
