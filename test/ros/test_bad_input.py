#!/usr/bin/python3
"""rostest: bad input through the node. An uncalibrated camera_info gives one fallback warning;
a wrong encoding, an empty image or a short buffer gives a throttled error and a not-detected
SpoolPose; the node keeps running and answers the next good frame. Every image goes with a
camera_info of its stamp (the node processes image + camera_info pairs)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from rosgraph_msgs.msg import Log

import drawn_frames as df
from pose_harness import DetectorClient, wait_until

THROTTLE_PERIOD = 5.0  # s, the node's ROS_ERROR_THROTTLE period


class BadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("bad_input_test")
        cls.client = DetectorClient()
        cls.client.connect()

    def send(self, image):
        return self.client.send(image, df.camera_info_msg())

    def good_frame(self, info=None):
        pose = self.client.send(df.image_msg(df.draw_spool(0.0, 0.8), "mono8"), info or df.camera_info_msg())
        self.assertTrue(pose.detected, "the node must still answer good frames")
        return pose

    def assert_rejected(self, image, why):
        pose = self.send(image)
        self.assertFalse(pose.detected, why)
        self.assertTrue(math.isnan(pose.distance), why)
        self.assertTrue(math.isnan(pose.reference_x), why)
        wait_until(lambda: self.client.log_lines(Log.ERROR, why), what="an error naming " + why)

    def test_1_uncalibrated_camera_info_falls_back_with_one_warning(self):
        for _ in range(5):
            pose = self.good_frame(df.camera_info_msg(calibrated=False))
            # The thesis camera scaled to 480 rows is f = 800 px, as these frames were drawn.
            truth = df.truth(0.0, 0.8)["distance"]
            self.assertAlmostEqual(pose.distance, truth, delta=0.02 * truth)
        self.good_frame(df.camera_info_msg(calibrated=False))  # still the fallback, no new warning
        wait_until(lambda: self.client.log_lines(Log.WARN, "falling back"), what="the fallback warning")
        self.assertEqual(len(self.client.log_lines(Log.WARN, "falling back")), 1)
        self.assertIn("thesis camera", self.client.log_lines(Log.WARN, "falling back")[0])

    def test_2_wrong_encoding(self):
        depth = np.full((df.HEIGHT, df.WIDTH), 0.8, np.float32)
        self.assert_rejected(df.image_msg(depth, "32FC1"), "32FC1")
        self.good_frame()

    def test_3_empty_image(self):
        self.assert_rejected(df.image_msg(np.zeros((0, 0), np.uint8), "mono8"), "empty image")
        self.good_frame()

    def test_4_short_buffer(self):
        image = df.image_msg(df.draw_spool(0.0, 0.8), "mono8")
        image.data = image.data[:1000]
        self.assert_rejected(image, "data holds 1000 bytes")
        self.good_frame()

    def test_5_unknown_encoding(self):
        self.assert_rejected(df.image_msg(df.draw_spool(0.0, 0.8), "no_such_encoding"),
                             "no_such_encoding")
        self.good_frame()

    def test_6_errors_are_throttled(self):
        time.sleep(THROTTLE_PERIOD)  # a fresh throttle window, then a burst of bad frames
        before = len(self.client.log_lines(Log.ERROR))
        start = time.time()
        bad = 30
        for _ in range(bad):
            self.send(df.image_msg(np.zeros((0, 0), np.uint8), "mono8"))
        elapsed = time.time() - start
        self.good_frame()  # every error of the burst was logged before this answer
        wait_until(lambda: len(self.client.log_lines(Log.ERROR)) > before, what="the burst's error")
        logged = len(self.client.log_lines(Log.ERROR)) - before
        # At most one line per throttle period that the burst touched, however long it took.
        self.assertLessEqual(logged, 1 + int(math.ceil(elapsed / THROTTLE_PERIOD)))
        self.assertLess(logged, bad)

    def test_7_each_kind_of_error_is_logged(self):
        # One throttle for all errors once hid a yuv422_yuy2 error behind an earlier, different
        # one: now each kind has its own. Two new kinds right after each other both show.
        self.send(df.image_msg(np.zeros((4, 4), np.uint16), "16UC3"))
        self.send(df.image_msg(df.draw_spool(0.0, 0.8), "another_unknown_encoding"))
        self.good_frame()
        wait_until(lambda: self.client.log_lines(Log.ERROR, "16UC3"), what="the 16UC3 error")
        wait_until(lambda: self.client.log_lines(Log.ERROR, "another_unknown_encoding"),
                   what="the second error, in the same throttle period")


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "bad_input", BadInputTest)
