#!/usr/bin/python3
"""rostest: a stream of images without camera_info. With use_camera_info false the node measures
each image with the thesis camera and says so once; a node left at use_camera_info true (which
processes image + camera_info pairs only) warns once that nothing is measured and names the fix."""
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log

from spool_vision.msg import SpoolPose

import drawn_frames as df
from pose_harness import DetectorClient, wait_until

# The paired node checks every 5 s of silence whether camera_info is published at all.
CHECK_PERIOD = 5.0


class ImageOnlyTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("image_only_test")
        # No camera_info publisher: the topic must stay unpublished for the paired node's check.
        cls.client = DetectorClient(publish_info=False)
        cls.client.connect()
        cls.paired = DetectorClient(node_name="/paired/paired_detector", publish=False)
        cls.paired.connect(publish=False)
        cls.paired_poses = []
        cls.paired_sub = rospy.Subscriber("/paired/spool_pose", SpoolPose, cls.paired_poses.append)
        wait_until(lambda: cls.paired_sub.get_num_connections() > 0, what="/paired/spool_pose publisher")
        wait_until(lambda: cls.client.image_pub.get_num_connections() >= 2, what="both detectors' image subscribers")

    def test_images_alone_are_measured_with_the_thesis_camera(self):
        for _ in range(3):
            pose = self.client.send(df.image_msg(df.draw_spool(0.0, 0.8), "mono8"))
            self.assertEqual(pose.header.frame_id, "test_camera")
            self.assertTrue(pose.detected)
            # The thesis camera scaled to 480 rows is f = 800 px, as these frames were drawn.
            self.assertAlmostEqual(pose.distance, 0.8, delta=0.02 * 0.8)
        wait_until(lambda: self.client.log_lines(Log.WARN, "falling back"), what="the fallback warning")
        lines = self.client.log_lines(Log.WARN, "falling back")
        self.assertEqual(len(lines), 1, lines)
        self.assertIn("use_camera_info is false", lines[0])
        self.assertIn("thesis camera", lines[0])

    def test_paired_node_says_why_it_measures_nothing(self):
        def images_sent_and_warned():
            self.client.send(df.image_msg(df.draw_spool(0.0, 0.8), "mono8"))
            return self.paired.log_lines(Log.WARN, "use_camera_info")
        wait_until(images_sent_and_warned, timeout=4 * CHECK_PERIOD, what="the missing camera_info warning")
        line = self.paired.log_lines(Log.WARN, "use_camera_info")[0]
        self.assertIn("/camera/camera_info", line)
        self.assertIn("/camera/image_raw", line)
        self.assertEqual(self.paired_poses, [], "no pose without camera_info")


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "image_only", ImageOnlyTest)
