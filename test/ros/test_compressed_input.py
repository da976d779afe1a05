#!/usr/bin/python3
"""rostest: sensor_msgs/CompressedImage input, subscribed by the node itself (Debian has no
compressed image_transport plugin). jpeg and png (8 and 16 bits) frames paired with their
camera_info measure like raw ones; undecodable data is logged and answered with an undefined
pose; a topic named .../compressed is read as compressed without the parameter. replay.launch
refuses a bag without the image topic it would play, naming the topics the bag holds."""
import os
import subprocess
import unittest

import cv2
import numpy as np
import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CompressedImage

import drawn_frames as df
from pose_harness import DetectorClient

REPLAY_LAUNCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "launch", "replay.launch")


def compressed(pixels, ext, encoding):
    ok, data = cv2.imencode(ext, pixels)
    assert ok
    msg = CompressedImage()
    msg.format = "%s; %s compressed %s" % (encoding, ext[1:], encoding)
    msg.data = data.tobytes()
    return msg


class CompressedInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("compressed_input_test")
        cls.client = DetectorClient(image_topic="/camera/image_raw/compressed", image_type=CompressedImage)
        cls.client.connect()
        cls.alone = DetectorClient(node_name="/alone/alone_detector", image_topic="/other/image/compressed",
                                   publish_info=False, image_type=CompressedImage, pose_topic="/alone/spool_pose")
        cls.alone.connect()

    def assert_measured(self, pose, depth):
        self.assertTrue(pose.detected)
        self.assertAlmostEqual(pose.distance, depth, delta=0.02 * depth)

    def test_jpeg_and_png_frames_measure_with_their_camera_info(self):
        grey = df.draw_spool(0.0, 0.8)
        colour = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
        frames = [compressed(colour, ".jpg", "bgr8"), compressed(grey, ".png", "mono8"),
                  compressed(grey.astype(np.uint16) * 257, ".png", "mono16")]
        for msg in frames:
            pose = self.client.send(msg, df.camera_info_msg())
            self.assert_measured(pose, 0.8)
            self.assertEqual(pose.header.frame_id, "test_camera")
        self.assertEqual(self.client.log_lines(Log.WARN, "falling back"), [])

    def test_undecodable_data_is_logged_and_answered(self):
        msg = CompressedImage(format="jpeg", data=b"\xff\xd8 not a jpeg at all")
        pose = self.client.send(msg, df.camera_info_msg())
        self.assertFalse(pose.detected)
        empty = self.client.send(CompressedImage(format="png"), df.camera_info_msg())
        self.assertFalse(empty.detected)
        # Still measuring afterwards.
        self.assert_measured(self.client.send(compressed(df.draw_spool(0.0, 0.7), ".jpg", "mono8"),
                                              df.camera_info_msg()), 0.7)
        errors = self.client.log_lines(Log.ERROR, "cannot process compressed image")
        self.assertTrue(any("cannot decode" in e and "'jpeg'" in e for e in errors), errors)
        self.assertTrue(any("no compressed data" in e for e in errors), errors)

    def test_topic_named_compressed_is_read_alone(self):
        pose = self.alone.send(compressed(df.draw_spool(0.0, 0.8), ".png", "mono8"))
        # The thesis camera scaled to 480 rows is f = 800 px, as these frames were drawn.
        self.assert_measured(pose, 0.8)

    def roslaunch(self, *args):
        bag = rospy.get_param("~compressed_bag")
        return subprocess.run(["roslaunch"] + list(args) + [REPLAY_LAUNCH, "bag:=" + bag], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, universal_newlines=True, timeout=60)

    def test_replay_refuses_a_bag_without_the_image_topic(self):
        # Refused while the launch file loads: nothing starts (--dump-params would exit 0).
        run = self.roslaunch()
        self.assertNotEqual(run.returncode, 0)
        self.assertIn("has no sensor_msgs/Image topic /camera/image_raw", run.stderr)
        self.assertIn("/camera/image_raw/compressed (sensor_msgs/CompressedImage)", run.stderr)
        self.assertIn("image:=/camera/image_raw image_transport:=compressed", run.stderr)

    def test_replay_plays_the_compressed_topic(self):
        for args in (["image_transport:=compressed"], ["image:=/camera/image_raw/compressed"]):
            run = self.roslaunch("--dump-params", *args)
            self.assertEqual(run.returncode, 0, run.stderr)
            self.assertIn("sensor_msgs/CompressedImage", run.stdout)
            self.assertIn("/spool_detector/image_transport: compressed", run.stdout)


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "compressed_input", CompressedInputTest)
