#!/usr/bin/python3
"""rostest: two spools 1 m ahead, one 10 cm left of the puller (the detector's own target: the
nearest in the image) and one 28 cm right (the slot the task wants). target_hint, given in the
camera's frame or in a world frame through TF, makes the tracker drop the near one and follow the
slot; a hint where no spool is leaves nothing followed."""
import math
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PointStamped, TransformStamped

import drawn_frames as df
from pose_harness import DetectorClient, wait_until

NEAR_X, SLOT_X, DEPTH = -0.10, 0.28, 1.0


def two_spools():
    near = df.draw_spool(NEAR_X, DEPTH)
    slot = df.draw_spool(SLOT_X, DEPTH)
    return np.where(slot != 170, slot, near).astype(np.uint8)


class TargetHintTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("target_hint_test")
        cls.client = DetectorClient()
        cls.client.connect()
        cls.hint_pub = rospy.Publisher("/target_hint", PointStamped, queue_size=1, latch=True)
        wait_until(lambda: cls.hint_pub.get_num_connections() > 0, what="target_hint subscriber")
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()

    def track(self, frames=6):
        """The SpoolPose of the last of `frames` frames of the two spools."""
        pose = None
        for _ in range(frames):
            pose = self.client.send(df.image_msg(two_spools(), "mono8"), df.camera_info_msg())
        return pose

    def hint(self, x, y, z, frame_id="test_camera"):
        msg = PointStamped()
        msg.header.frame_id = frame_id
        msg.point.x, msg.point.y, msg.point.z = x, y, z
        self.hint_pub.publish(msg)
        rospy.sleep(0.3)  # the latched hint reaches the node before the next frame

    def test_1_without_a_hint_the_nearest_spool_is_followed(self):
        pose = self.track()
        self.assertTrue(pose.detected)
        self.assertAlmostEqual(pose.lateral_offset, NEAR_X, delta=0.01)

    def test_2_a_hint_in_the_camera_frame_moves_the_track_to_the_slot(self):
        self.hint(SLOT_X + 0.04, df.PULLER_BELOW_CAMERA, DEPTH - 0.03)
        pose = self.track()
        self.assertTrue(pose.detected)
        self.assertAlmostEqual(pose.lateral_offset, SLOT_X, delta=0.01)

    def test_3_a_hint_in_a_world_frame_goes_through_tf(self):
        # odom -> test_camera: the camera 2 m along odom's x, 1 m along its y; identity rotation.
        t = TransformStamped()
        t.header.stamp = rospy.Time(0)
        t.header.frame_id = "odom"
        t.child_frame_id = "test_camera"
        t.transform.translation.x, t.transform.translation.y = 2.0, 1.0
        t.transform.rotation.w = 1.0
        self.static_tf.sendTransform(t)
        self.hint(2.0 + NEAR_X, 1.0 + df.PULLER_BELOW_CAMERA, DEPTH, frame_id="odom")
        pose = self.track()
        self.assertTrue(pose.detected)
        self.assertAlmostEqual(pose.lateral_offset, NEAR_X, delta=0.01)

    def test_4_a_hint_where_no_spool_is_leaves_nothing_followed(self):
        self.hint(0.09, df.PULLER_BELOW_CAMERA, DEPTH)
        # 0.15 m of target_hint_radius reaches neither bore (19 cm away each).
        pose = self.track(frames=10)
        self.assertFalse(pose.detected)
        self.assertTrue(math.isnan(pose.distance))
        self.hint(float("nan"), 0.0, 0.0)  # withdrawn: the nearest spool again
        pose = self.track()
        self.assertTrue(pose.detected)
        self.assertAlmostEqual(pose.lateral_offset, NEAR_X, delta=0.01)


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "target_hint", TargetHintTest)
