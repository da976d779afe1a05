// Pairs each image with the camera_info of the same stamp, whichever comes first, as
// message_filters' ExactTime policy (inside image_transport's CameraSubscriber) does, except
// that a pair completed for a later stamp does not drop the earlier stamps still waiting. At a
// bag loop's start the first frame's camera_info can come before the last frame's image (two
// topics, two connections), and ExactTime then threw the first frame away.
#pragma once

#include <algorithm>
#include <cstddef>
#include <deque>
#include <functional>
#include <utility>

#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <boost/shared_ptr.hpp>

namespace spool_vision
{
template <typename Image>
class StampPairing
{
public:
  using ImagePtr = boost::shared_ptr<const Image>;
  using Callback = std::function<void(const ImagePtr&, const sensor_msgs::CameraInfoConstPtr&)>;

  /// At most `capacity` stamps wait for their other half; the first to arrive is dropped first.
  StampPairing(std::size_t capacity, Callback callback)
    : capacity_(std::max<std::size_t>(capacity, 1)), callback_(std::move(callback))
  {
  }

  void addImage(const ImagePtr& image)
  {
    add(image->header.stamp, image, nullptr);
  }

  void addInfo(const sensor_msgs::CameraInfoConstPtr& info)
  {
    add(info->header.stamp, nullptr, info);
  }

private:
  struct Waiting
  {
    ros::Time stamp;
    ImagePtr image;
    sensor_msgs::CameraInfoConstPtr info;
  };

  void add(const ros::Time& stamp, const ImagePtr& image, const sensor_msgs::CameraInfoConstPtr& info)
  {
    const auto it = std::find_if(waiting_.begin(), waiting_.end(), [&](const Waiting& w) { return w.stamp == stamp; });
    if (it == waiting_.end())
    {
      if (waiting_.size() >= capacity_)
        waiting_.pop_front();
      waiting_.push_back({stamp, image, info});
      return;
    }
    if (image)
      it->image = image;
    else
      it->info = info;
    if (!it->image || !it->info)
      return;
    const Waiting pair = std::move(*it);
    waiting_.erase(it);
    callback_(pair.image, pair.info);
  }

  std::size_t capacity_;
  Callback callback_;
  std::deque<Waiting> waiting_;
};

}  // namespace spool_vision
