// SpoolDetection -> SpoolPose: units pass through, undefined numbers are NaN, the header is kept.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <tf2/buffer_core.h>

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
  d.range = 0.5533;
  d.position = cv::Point3d(-0.0005, 0.06, 0.55);
  d.axis = cv::Vec3d(0.0, 0.0, 1.0);
  d.axis_angle = 0.0;
  d.axis_yaw = 0.0;
  d.lens_detected = true;

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
  EXPECT_DOUBLE_EQ(pose.range, 0.5533);
  EXPECT_DOUBLE_EQ(pose.position.x, -0.0005);
  EXPECT_DOUBLE_EQ(pose.position.y, 0.06);
  EXPECT_DOUBLE_EQ(pose.position.z, 0.55);
  EXPECT_DOUBLE_EQ(pose.axis.z, 1.0);
  EXPECT_DOUBLE_EQ(pose.axis_angle, 0.0);
  EXPECT_DOUBLE_EQ(pose.axis_yaw, 0.0);
  EXPECT_TRUE(pose.bore_see_through);
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
  d.range = 1.0;
  d.position = cv::Point3d(0.0, 0.06, 1.0);
  d.axis = cv::Vec3d(0.0, 0.0, 1.0);
  d.axis_angle = d.axis_yaw = 0.0;
  d.lens_detected = true;
  d.flange = Circle{1.0, 2.0, 3.0};
  d.confidence = 0.4;
  d.tolerance = 0.0025;
  d.reference = cv::Point2d(319.5, 290.0);
  const SpoolPose pose = toSpoolPose(d, header());
  EXPECT_FALSE(pose.detected || pose.hole_detected || pose.overlapped || pose.aligned);
  for (double v : {pose.distance, pose.range, pose.yaw, pose.lateral_offset, pose.position.x, pose.position.y,
                   pose.position.z, pose.axis.x, pose.axis.y, pose.axis.z, pose.axis_angle, pose.axis_yaw,
                   pose.flange_x, pose.flange_y, pose.flange_radius, pose.hole_x, pose.hole_y, pose.hole_radius})
    EXPECT_TRUE(std::isnan(v));
  EXPECT_FALSE(pose.bore_see_through);
  EXPECT_FALSE(spoolPose3d(d));
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

// Rotates v by the pose's orientation (q v q*).
cv::Vec3d rotate(const geometry_msgs::Quaternion& q, const cv::Vec3d& v)
{
  const cv::Vec3d u(q.x, q.y, q.z);
  return 2.0 * u.dot(v) * u + (q.w * q.w - u.dot(u)) * v + 2.0 * q.w * u.cross(v);
}

SpoolDetection detectedAt(const cv::Point3d& position, const cv::Vec3d& axis)
{
  SpoolDetection d;
  d.detected = true;
  d.position = position;
  d.axis = axis;
  return d;
}

void expectNear(const cv::Vec3d& a, const cv::Vec3d& b)
{
  EXPECT_LT(cv::norm(a - b), 1e-9) << a << " vs " << b;
}

TEST(PoseConversion, SpoolStraightAheadHasTheCameraOrientation)
{
  const auto pose = spoolPose3d(detectedAt(cv::Point3d(0.01, 0.06, 0.8), cv::Vec3d(0.0, 0.0, 1.0)));
  ASSERT_TRUE(pose);
  EXPECT_DOUBLE_EQ(pose->position.x, 0.01);
  EXPECT_DOUBLE_EQ(pose->position.y, 0.06);
  EXPECT_DOUBLE_EQ(pose->position.z, 0.8);
  EXPECT_NEAR(std::abs(pose->orientation.w), 1.0, 1e-12);
}

TEST(PoseConversion, OrientationZIsTheAxisAndXStaysLevel)
{
  for (const cv::Vec3d& raw :
       {cv::Vec3d(0.3, 0.0, 1.0), cv::Vec3d(-0.5, 0.1, 0.8), cv::Vec3d(0.0, -0.2, 1.0), cv::Vec3d(-0.9, 0.05, 0.1)})
  {
    const cv::Vec3d axis = cv::normalize(raw);
    const auto pose = spoolPose3d(detectedAt(cv::Point3d(0.0, 0.06, 0.7), axis));
    ASSERT_TRUE(pose);
    const auto& q = pose->orientation;
    EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-12);
    expectNear(rotate(q, cv::Vec3d(0.0, 0.0, 1.0)), axis);
    const cv::Vec3d x = rotate(q, cv::Vec3d(1.0, 0.0, 0.0));
    EXPECT_NEAR(x[1], 0.0, 1e-12) << "x must lie in the camera's horizontal plane";
    EXPECT_GT(x[0], 0.0) << "x points to the camera's right for a spool facing it";
    EXPECT_GT(rotate(q, cv::Vec3d(0.0, 1.0, 0.0))[1], 0.0) << "y points down";
  }
}

TEST(PoseConversion, NoPoseWithoutAFinitePositionAndAxis)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(spoolPose3d(detectedAt(cv::Point3d(nan, nan, nan), cv::Vec3d(0.0, 0.0, 1.0))));
  EXPECT_FALSE(spoolPose3d(detectedAt(cv::Point3d(0.0, 0.06, 0.8), cv::Vec3d(nan, nan, nan))));
  EXPECT_FALSE(spoolPose3d(detectedAt(cv::Point3d(0.0, 0.06, 0.8), cv::Vec3d(0.0, 0.0, 0.0))));
  SpoolDetection not_detected = detectedAt(cv::Point3d(0.0, 0.06, 0.8), cv::Vec3d(0.0, 0.0, 1.0));
  not_detected.detected = false;
  EXPECT_FALSE(spoolPose3d(not_detected));
}

TEST(PoseConversion, MarkerIsTheSpoolBehindItsFrontFace)
{
  const cv::Vec3d axis = cv::normalize(cv::Vec3d(0.4, 0.0, 1.0));
  const auto pose = spoolPose3d(detectedAt(cv::Point3d(0.05, 0.06, 0.9), axis));
  ASSERT_TRUE(pose);
  const auto marker = spoolMarker(header(), pose, 0.35, 0.2);
  EXPECT_EQ(marker.header.frame_id, "camera_optical_frame");
  EXPECT_EQ(marker.header.stamp, ros::Time(12, 345));
  EXPECT_EQ(marker.action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(marker.type, visualization_msgs::Marker::CYLINDER);
  EXPECT_DOUBLE_EQ(marker.scale.x, 0.35);
  EXPECT_DOUBLE_EQ(marker.scale.y, 0.35);
  EXPECT_DOUBLE_EQ(marker.scale.z, 0.2);
  // The cylinder's centre lies half its length along the axis from the bore's front centre.
  const cv::Vec3d centre(marker.pose.position.x, marker.pose.position.y, marker.pose.position.z);
  expectNear(centre, cv::Vec3d(0.05, 0.06, 0.9) + 0.1 * axis);
  expectNear(rotate(marker.pose.orientation, cv::Vec3d(0.0, 0.0, 1.0)), axis);
  EXPECT_GT(marker.color.a, 0.0f);
}

TEST(PoseConversion, MarkerWithoutASpoolDeletesIt)
{
  const auto marker = spoolMarker(header(), std::nullopt, 0.35, 0.2);
  EXPECT_EQ(marker.action, visualization_msgs::Marker::DELETE);
  EXPECT_EQ(marker.ns, "spool");
  EXPECT_EQ(marker.id, 0);
  EXPECT_EQ(marker.header.frame_id, "camera_optical_frame");
}

}  // namespace
TEST(PoseConversion, CameraMotionFromTfMovesAFixedPointAsTheCameraSeesIt)
{
  // REP 105 odometry: base_link 10 cm forward and turned 0.1 rad left between two stamps; the
  // camera's optical frame on base_link as REP 103 turns it. A point fixed in odom, 1 m ahead and
  // 20 cm left at the first stamp, must land where the second camera sees it.
  tf2::BufferCore buffer;
  geometry_msgs::TransformStamped mount;
  mount.header.frame_id = "base_link";
  mount.child_frame_id = "camera_optical";
  mount.transform.rotation.x = -0.5;
  mount.transform.rotation.y = 0.5;
  mount.transform.rotation.z = -0.5;
  mount.transform.rotation.w = 0.5;
  ASSERT_TRUE(buffer.setTransform(mount, "test", true));
  const double turn = 0.1;
  for (int i = 0; i < 2; ++i)
  {
    geometry_msgs::TransformStamped base;
    base.header.frame_id = "odom";
    base.header.stamp = ros::Time(1.0 + i);
    base.child_frame_id = "base_link";
    base.transform.translation.x = 0.1 * i;
    base.transform.rotation.z = std::sin(0.5 * turn * i);
    base.transform.rotation.w = std::cos(0.5 * turn * i);
    ASSERT_TRUE(buffer.setTransform(base, "test"));
  }
  const CameraMotion motion = toCameraMotion(
      buffer.lookupTransform("camera_optical", ros::Time(2.0), "camera_optical", ros::Time(1.0), "odom").transform);
  // The second base frame sees the point at R(-turn) (point - (0.1, 0)); optical = (-y, -z, x).
  const double ahead = std::cos(turn) * 0.9 + std::sin(turn) * 0.2;
  const double left = -std::sin(turn) * 0.9 + std::cos(turn) * 0.2;
  const cv::Vec3d seen = motion.rotation * cv::Vec3d(-0.2, 0.0, 1.0) + motion.translation;
  EXPECT_NEAR(seen[0], -left, 1e-9);
  EXPECT_NEAR(seen[1], 0.0, 1e-9);
  EXPECT_NEAR(seen[2], ahead, 1e-9);
}

}  // namespace spool_vision
