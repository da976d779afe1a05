#!/usr/bin/python3
"""rostest: the node reads each image's camera_info as image_geometry does (K and D for a raw
image, P for a rectified one; another size scaled or refused) and publishes the spool in 3D:
~pose (PoseStamped), the TF frame spool under the image's frame_id, and ~marker.

The drawn frames show a fronto-parallel spool (its axis along the optical axis) whose bore's
front centre is at (x, 0.06, z) in the camera optical frame. The 3D checks (position, axis, TF,
an ADD marker) need the core's position and axis; they fail while those are NaN."""
import math
import time
import unittest

import cv2
import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Log
from visualization_msgs.msg import Marker

import drawn_frames as df
from pose_harness import DetectorClient, StampedMessages, wait_until

FRAME_ID = "test_camera"


def rotate(q, v):
    """v rotated by quaternion q (geometry_msgs/Quaternion)."""
    u = np.array([q.x, q.y, q.z])
    v = np.asarray(v, float)
    return 2.0 * u.dot(v) * u + (q.w * q.w - u.dot(u)) * v + 2.0 * q.w * np.cross(u, v)


def xyz(p):
    return np.array([p.x, p.y, p.z])


class CameraModelTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("camera_model_test")
        cls.client = DetectorClient()
        cls.client.connect()
        cls.poses = StampedMessages("/spool_detector/pose", PoseStamped)
        cls.markers = StampedMessages("/spool_detector/marker", Marker)
        cls.poses.connect()
        cls.markers.connect()
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)

    def send(self, pixels, info):
        return self.client.send(df.image_msg(np.ascontiguousarray(pixels), "mono8"), info, FRAME_ID)

    def logged(self, level, *texts):
        return [line for line in self.client.log_lines(level) if all(t in line for t in texts)]

    def assert_depth(self, pose, depth, why):
        self.assertTrue(pose.detected, why)
        self.assertAlmostEqual(pose.distance, depth, delta=0.02 * depth, msg=why)

    # --- the camera model ----------------------------------------------------------------------

    def test_raw_image_is_measured_with_k(self):
        # image_raw: D non-zero (negligibly small, so the drawing stays right), P of another
        # focal length. Measured with P the spool would be 12% nearer.
        info = df.camera_info_msg(p_focal=700.0, d=(1e-9, 0.0, 0.0, 0.0, 0.0))
        self.assert_depth(self.send(df.draw_spool(0.0, 0.8), info), 0.8, "raw image measured with K")

    def test_rectified_image_is_measured_with_p(self):
        # image_rect: D all zero; P describes the image, K (here 12% longer) the raw one.
        info = df.camera_info_msg(k_focal=900.0, d=(0.0,) * 5)
        self.assert_depth(self.send(df.draw_spool(0.0, 0.8), info), 0.8, "rectified image measured with P")

    def test_rational_polynomial_is_accepted(self):
        info = df.camera_info_msg(p_focal=700.0, d=(1e-9,) + (0.0,) * 7, model="rational_polynomial")
        self.assert_depth(self.send(df.draw_spool(0.0, 0.8), info), 0.8, "rational_polynomial with K")

    def test_smaller_image_of_the_same_aspect_is_scaled_with_one_warning(self):
        small = cv2.resize(df.draw_spool(0.0, 0.8), (df.WIDTH // 2, df.HEIGHT // 2), interpolation=cv2.INTER_AREA)
        before = len(self.logged(Log.WARN, "scaled"))
        for _ in range(3):
            self.assert_depth(self.send(small, df.camera_info_msg()), 0.8, "640x480 calibration scaled to 320x240")
        wait_until(lambda: len(self.logged(Log.WARN, "scaled")) > before, what="the scaling warning")
        time.sleep(0.5)  # a repeated warning would show up now
        lines = self.logged(Log.WARN, "scaled")[before:]
        self.assertEqual(len(lines), 1, lines)
        self.assertIn("640x480", lines[0])
        self.assertIn("320x240", lines[0])

    def test_image_of_another_aspect_is_refused_with_one_error(self):
        # A 640x360 crop of a 640x480 frame: no scaling of the calibration describes it.
        crop = df.draw_spool(0.0, 0.8)[60:420]
        before = len(self.logged(Log.ERROR, "640x360"))
        for _ in range(3):
            pose = self.send(crop, df.camera_info_msg())
            self.assertEqual(pose.header.frame_id, FRAME_ID)
        wait_until(lambda: len(self.logged(Log.ERROR, "640x360")) > before, what="the refusal")
        time.sleep(0.5)
        lines = self.logged(Log.ERROR, "640x360")[before:]
        self.assertEqual(len(lines), 1, lines)
        for text in ("640x480", "aspect ratio", "calibrate the camera at 640x360", "thesis camera"):
            self.assertIn(text, lines[0])
        # A frame of the calibrated size is measured with its camera_info again.
        self.assert_depth(self.send(df.draw_spool(0.0, 0.8), df.camera_info_msg(k_focal=900.0, p_focal=900.0)),
                          0.9, "back to the camera_info after a refused one")

    def test_equidistant_model_is_refused(self):
        info = df.camera_info_msg(d=(0.1, 0.01, 0.0, 0.0), model="equidistant")
        before = len(self.logged(Log.ERROR, "'equidistant'"))
        self.send(df.draw_spool(0.0, 0.8), info)
        wait_until(lambda: len(self.logged(Log.ERROR, "'equidistant'")) > before, what="the refusal")
        self.assertIn("plumb_bob", self.logged(Log.ERROR, "'equidistant'")[-1])

    # --- the spool in 3D -----------------------------------------------------------------------

    def detected_spool(self, x=0.05, z=0.8):
        pose = self.send(df.draw_spool(x, z), df.camera_info_msg())
        self.assertTrue(pose.detected)
        return pose

    def test_spool_pose_has_position_and_axis(self):  # waits for the core's position and axis
        pose = self.detected_spool()
        position = xyz(pose.position)
        self.assertAlmostEqual(pose.position.z, pose.distance, places=9, msg="distance is the depth z")
        np.testing.assert_allclose(position, [0.05, df.PULLER_BELOW_CAMERA, 0.8], atol=0.016)
        self.assertAlmostEqual(pose.range, np.linalg.norm(position), places=9)
        axis = xyz(pose.axis)
        self.assertAlmostEqual(np.linalg.norm(axis), 1.0, places=6)
        self.assertLess(pose.axis_angle, 0.05, "a fronto-parallel spool's axis is the optical axis")
        self.assertAlmostEqual(pose.axis_angle, math.acos(axis[2]), places=6)
        self.assertAlmostEqual(pose.axis_yaw, math.atan2(axis[0], axis[2]), places=6)

    def test_pose_stamped_is_the_bore_front_centre_with_z_along_the_axis(self):  # waits for the core
        spool = self.detected_spool()
        pose = self.poses.get(spool.header.stamp)
        self.assertEqual(pose.header.frame_id, FRAME_ID)
        self.assertEqual(pose.header.stamp, spool.header.stamp)
        np.testing.assert_allclose(xyz(pose.pose.position), xyz(spool.position), atol=1e-9)
        self.assertAlmostEqual(pose.pose.position.z, spool.distance, places=9)
        q = pose.pose.orientation
        self.assertAlmostEqual(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2, 1.0, places=6)
        np.testing.assert_allclose(rotate(q, [0, 0, 1]), xyz(spool.axis), atol=1e-6)
        self.assertAlmostEqual(rotate(q, [1, 0, 0])[1], 0.0, places=6, msg="x axis level")

    def test_tf_frame_spool_under_the_image_frame(self):  # waits for the core
        spool = self.detected_spool()
        transform = self.tf_buffer.lookup_transform(FRAME_ID, "spool", spool.header.stamp, rospy.Duration(10.0))
        self.assertEqual(transform.header.frame_id, FRAME_ID)
        self.assertEqual(transform.child_frame_id, "spool")
        self.assertEqual(transform.header.stamp, spool.header.stamp)
        np.testing.assert_allclose(xyz(transform.transform.translation), xyz(spool.position), atol=1e-9)
        np.testing.assert_allclose(rotate(transform.transform.rotation, [0, 0, 1]), xyz(spool.axis), atol=1e-6)

    def test_marker_is_the_spool_as_a_cylinder(self):  # waits for the core
        spool = self.detected_spool()
        marker = self.markers.get(spool.header.stamp)
        self.assertEqual(marker.header.frame_id, FRAME_ID)
        self.assertEqual(marker.action, Marker.ADD)
        self.assertEqual(marker.type, Marker.CYLINDER)
        self.assertAlmostEqual(marker.scale.x, 0.35)
        self.assertAlmostEqual(marker.scale.y, 0.35)
        self.assertAlmostEqual(marker.scale.z, 0.2)
        # Front face on the bore's front centre: the centre lies half the hub along the axis.
        np.testing.assert_allclose(xyz(marker.pose.position), xyz(spool.position) + 0.1 * xyz(spool.axis), atol=1e-6)

    def test_no_spool_deletes_the_marker_and_publishes_no_pose(self):
        self.detected_spool()
        empty = self.send(np.full((df.HEIGHT, df.WIDTH), 170, np.uint8), df.camera_info_msg())
        self.assertFalse(empty.detected)
        for field in ("range", "axis_angle", "axis_yaw"):
            self.assertTrue(math.isnan(getattr(empty, field)), field)
        self.assertTrue(all(math.isnan(v) for v in xyz(empty.position)))
        self.assertTrue(all(math.isnan(v) for v in xyz(empty.axis)))
        self.assertFalse(empty.bore_see_through)
        marker = self.markers.get(empty.header.stamp)
        self.assertEqual(marker.action, Marker.DELETE)
        self.assertEqual(marker.header.frame_id, FRAME_ID)
        # The marker of the next frame comes after any pose of this one.
        after = self.send(np.full((df.HEIGHT, df.WIDTH), 170, np.uint8), df.camera_info_msg())
        self.markers.get(after.header.stamp)
        time.sleep(0.5)
        self.assertFalse(self.poses.has(empty.header.stamp))


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "camera_model", CameraModelTest)
