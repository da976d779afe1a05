// A minimal V4L2 camera source for machines without usb_cam (Debian ships none): OpenCV's
// VideoCapture grabs frames, camera_info_manager supplies the calibration, and image_raw +
// camera_info are published with the same header.
#include <string>

#include <camera_info_manager/camera_info_manager.h>
#include <cv_bridge/cv_bridge.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/image_encodings.h>
#include <opencv2/videoio.hpp>

namespace
{
bool openCamera(cv::VideoCapture& capture, const std::string& device, int width, int height, double fps)
{
  // A number selects /dev/videoN through V4L2; anything else (a path, a video file) is opened as given.
  const bool is_index = !device.empty() && device.find_first_not_of("0123456789") == std::string::npos;
  const bool opened = is_index ? capture.open(std::stoi(device), cv::CAP_V4L2) : capture.open(device);
  if (!opened)
    return false;
  capture.set(cv::CAP_PROP_FRAME_WIDTH, width);
  capture.set(cv::CAP_PROP_FRAME_HEIGHT, height);
  capture.set(cv::CAP_PROP_FPS, fps);
  return true;
}

// Publishes `frame` stamped now, with the calibration (or, uncalibrated, a camera_info of zero
// K that still gives the frame's size).
void publishFrame(const cv::Mat& frame, const std::string& frame_id,
                  camera_info_manager::CameraInfoManager& info_manager, image_transport::CameraPublisher& publisher)
{
  std_msgs::Header header;
  header.stamp = ros::Time::now();
  header.frame_id = frame_id;
  sensor_msgs::CameraInfo info = info_manager.getCameraInfo();
  info.header = header;
  if (!info_manager.isCalibrated())
  {
    info.width = frame.cols;
    info.height = frame.rows;
  }
  const std::string& encoding =
      frame.channels() == 1 ? sensor_msgs::image_encodings::MONO8 : sensor_msgs::image_encodings::BGR8;
  publisher.publish(*cv_bridge::CvImage(header, encoding, frame).toImageMsg(), info);
}

}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "camera");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");

  const std::string device = pnh.param<std::string>("device", "/dev/video0");
  const int width = pnh.param("width", 640);
  const int height = pnh.param("height", 480);
  const double fps = pnh.param("fps", 30.0);
  const std::string frame_id = pnh.param<std::string>("frame_id", "camera_optical_frame");
  const std::string camera_name = pnh.param<std::string>("camera_name", "camera");
  const std::string camera_info_url = pnh.param<std::string>("camera_info_url", "");
  if (width <= 0 || height <= 0 || !(fps > 0.0))
  {
    ROS_FATAL("camera: width, height and fps must be positive (got %dx%d at %.1f)", width, height, fps);
    return 1;
  }

  // In the camera namespace, as camera_calibration expects (set_camera_info beside image_raw).
  camera_info_manager::CameraInfoManager info_manager(nh, camera_name, camera_info_url);
  if (!info_manager.isCalibrated())
    ROS_WARN("camera: no calibration at '%s'; camera_info will carry a zero K", camera_info_url.c_str());

  image_transport::ImageTransport it(nh);
  image_transport::CameraPublisher publisher = it.advertiseCamera("image_raw", 1);

  cv::VideoCapture capture;
  if (!openCamera(capture, device, width, height, fps))
  {
    ROS_FATAL("camera: cannot open '%s'", device.c_str());
    return 1;
  }
  ROS_INFO("camera: %s at %.0fx%.0f, %.1f fps", device.c_str(), capture.get(cv::CAP_PROP_FRAME_WIDTH),
           capture.get(cv::CAP_PROP_FRAME_HEIGHT), capture.get(cv::CAP_PROP_FPS));

  cv::Mat frame;
  ros::Rate rate(fps);
  while (ros::ok())
  {
    if (!capture.read(frame) || frame.empty())
    {
      // A webcam that was unplugged comes back under the same name: keep trying.
      ROS_ERROR_THROTTLE(5.0, "camera: no frame from '%s'; reopening", device.c_str());
      capture.release();
      ros::Duration(0.5).sleep();
      openCamera(capture, device, width, height, fps);
      continue;
    }
    publishFrame(frame, frame_id, info_manager, publisher);
    ros::spinOnce();
    rate.sleep();
  }
  return 0;
}
