// The spool detector as a nodelet, for zero-copy images from a camera nodelet in one manager.
#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "ros_params.h"
#include "spool_detector_ros.h"

namespace spool_vision
{
class SpoolDetectorNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      // getNodeHandle() and getPrivateNodeHandle() share the nodelet's single-threaded queue,
      // which SpoolDetectorRos relies on.
      detector_ = std::make_unique<SpoolDetectorRos>(getNodeHandle(), getPrivateNodeHandle(), getName());
    }
    catch (const std::exception& e)
    {
      NODELET_FATAL("refusing to start: %s", refusalMessage(getName(), e).c_str());
      throw;  // the manager then reports the load as failed
    }
  }

  std::unique_ptr<SpoolDetectorRos> detector_;
};

}  // namespace spool_vision

PLUGINLIB_EXPORT_CLASS(spool_vision::SpoolDetectorNodelet, nodelet::Nodelet)
