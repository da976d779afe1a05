// SpoolDetection -> SpoolPose: units pass through, undefined numbers are NaN, the header is kept.
#include <cmath>

#include <gtest/gtest.h>

#include "../../src/ros/pose_conversion.h"

namespace spool_vision
{
namespace
{
std_msgs::Header header()
{
  std_msgs::Header h;
  h.seq = 7;
  h.stamp = ros::Time(12, 345);
  h.frame_id = "camera_optical_frame";
  return h;
}

TEST(PoseConversion, DetectionIsCopiedWithTheImageHeader)
{
  SpoolDetection d;
  d.detected = d.hole_detected = d.overlapped = d.aligned = true;
  d.distance = 0.55;
  d.yaw = -0.001;
  d.lateral_offset = 0.55 * std::tan(-0.001);
  d.tolerance = 0.0025;
  d.confidence = 0.9;
  d.flange = Circle{320.0, 330.0, 255.0};
  d.hole = Circle{320.5, 330.5, 26.0};
  d.reference = cv::Point2d(319.5, 326.8);

  const SpoolPose pose = toSpoolPose(d, header());
  EXPECT_EQ(pose.header.seq, 7u);
  EXPECT_EQ(pose.header.stamp, ros::Time(12, 345));
  EXPECT_EQ(pose.header.frame_id, "camera_optical_frame");
  EXPECT_TRUE(pose.detected && pose.hole_detected && pose.overlapped && pose.aligned);
  EXPECT_DOUBLE_EQ(pose.distance, 0.55);
  EXPECT_DOUBLE_EQ(pose.yaw, -0.001);
  EXPECT_DOUBLE_EQ(pose.lateral_offset, d.lateral_offset);
  EXPECT_DOUBLE_EQ(pose.tolerance, 0.0025);
  EXPECT_DOUBLE_EQ(pose.flange_x, 320.0);
  EXPECT_DOUBLE_EQ(pose.flange_y, 330.0);
  EXPECT_DOUBLE_EQ(pose.flange_radius, 255.0);
  EXPECT_DOUBLE_EQ(pose.hole_x, 320.5);
  EXPECT_DOUBLE_EQ(pose.hole_y, 330.5);
  EXPECT_DOUBLE_EQ(pose.hole_radius, 26.0);
  EXPECT_DOUBLE_EQ(pose.reference_x, 319.5);
  EXPECT_DOUBLE_EQ(pose.reference_y, 326.8);
  EXPECT_DOUBLE_EQ(pose.confidence, 0.9);
}

TEST(PoseConversion, FlangeWithoutHoleLeavesTheHoleUndefined)
{
  SpoolDetection d;
  d.detected = true;
  d.distance = 0.9;
  d.yaw = 0.01;
  d.lateral_offset = 0.009;
  d.flange = Circle{300.0, 280.0, 155.0};
  d.hole = Circle{1.0, 2.0, 3.0};  // stale numbers from a rejected candidate must not leak
  const SpoolPose pose = toSpoolPose(d, header());
  EXPECT_TRUE(pose.detected);
  EXPECT_FALSE(pose.hole_detected);
  EXPECT_TRUE(std::isnan(pose.hole_x));
  EXPECT_TRUE(std::isnan(pose.hole_y));
  EXPECT_TRUE(std::isnan(pose.hole_radius));
  EXPECT_DOUBLE_EQ(pose.flange_radius, 155.0);
}

TEST(PoseConversion, NothingDetectedIsNaN)
{
  SpoolDetection d;
  d.distance = 1.0;  // stale numbers must not leak into an undetected frame
  d.flange = Circle{1.0, 2.0, 3.0};
  d.confidence = 0.4;
  d.tolerance = 0.0025;
  d.reference = cv::Point2d(319.5, 290.0);
  const SpoolPose pose = toSpoolPose(d, header());
  EXPECT_FALSE(pose.detected || pose.hole_detected || pose.overlapped || pose.aligned);
  for (double v : {pose.distance, pose.yaw, pose.lateral_offset, pose.flange_x, pose.flange_y, pose.flange_radius,
                   pose.hole_x, pose.hole_y, pose.hole_radius})
    EXPECT_TRUE(std::isnan(v));
  EXPECT_EQ(pose.confidence, 0.0);
  EXPECT_DOUBLE_EQ(pose.reference_y, 290.0);
  EXPECT_DOUBLE_EQ(pose.tolerance, 0.0025);
}

TEST(PoseConversion, UnprocessedFrameKeepsOnlyHeaderAndTolerance)
{
  const SpoolPose pose = undefinedSpoolPose(header(), 0.0025);
  EXPECT_EQ(pose.header.frame_id, "camera_optical_frame");
  EXPECT_FALSE(pose.detected);
  EXPECT_TRUE(std::isnan(pose.distance));
  EXPECT_TRUE(std::isnan(pose.reference_x));
  EXPECT_TRUE(std::isnan(pose.reference_y));
  EXPECT_DOUBLE_EQ(pose.tolerance, 0.0025);
}

}  // namespace
}  // namespace spool_vision
