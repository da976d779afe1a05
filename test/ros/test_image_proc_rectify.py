#!/usr/bin/python3
"""rostest: image_proc's rectify nodelet in front of the detector (image_proc_rectify.test).

Frames of a C270-like lens (plumb_bob D, k1 = -0.2) go out on /camera/image_raw with their
camera_info. image_proc/rectify, in the same nodelet manager as one detector, publishes
/camera/image_rect beside the same camera_info (D still the lens's); that detector reads it with P
and must not undistort again, and says so once. A second detector reads image_raw with K and D.
Both must give the spool's depth and bearing within the quality bars (DESIGN.md section 7: depth
p95 1.5%, bearing p95 0.2 deg) of the truth and of each other."""
import math
import threading
import unittest

import cv2
import numpy as np
import rospy
import rostest
from rosgraph_msgs.msg import Log

import drawn_frames as df
from pose_harness import DetectorClient, wait_until
from spool_vision.msg import SpoolPose

D = (-0.2, 0.05, 0.001, -0.0005, 0.0)
K = np.array([[df.FOCAL, 0.0, df.CX], [0.0, df.FOCAL, df.CY], [0.0, 0.0, 1.0]])
# (x, z) of the spool: centred, and far enough off the centre that the lens bends its rim by
# several percent (undistorting twice, or not at all, would move the depth by as much).
SPOOLS = [(0.0, 0.8), (0.12, 0.8), (-0.15, 0.95), (0.06, 0.6), (-0.05, 1.05)]
DEPTH_TOLERANCE = 0.015  # of the depth
BEARING_TOLERANCE = math.radians(0.2)


def raw_frame(ideal):
    """The frame the lens makes of `ideal` (an image of the ideal camera K): each raw pixel shows
    the ideal image where cv2.undistortPoints puts it."""
    h, w = ideal.shape
    grid = np.stack(np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32)), -1)
    ideal_at = cv2.undistortPoints(grid.reshape(-1, 1, 2), K, np.array(D), P=K).reshape(h, w, 2)
    return cv2.remap(ideal, ideal_at[..., 0], ideal_at[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


class ImageProcRectifyTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("image_proc_rectify_test")
        cls.raw = DetectorClient(node_name="/raw/spool_detector", pose_topic="/raw/spool_pose")
        cls.lock = threading.Lock()
        cls.rect_poses = {}
        cls.manager_log = []
        cls.rect_sub = rospy.Subscriber("/rect/spool_pose", SpoolPose, cls.on_rect_pose, queue_size=100)
        cls.log_sub = rospy.Subscriber("/rosout", Log, cls.on_log, queue_size=1000)
        cls.raw.connect()
        wait_until(lambda: cls.rect_sub.get_num_connections() > 0, what="/rect/spool_pose publisher")
        # image_proc subscribes image_raw only once someone subscribes image_rect (lazy).
        wait_until(lambda: cls.raw.image_pub.get_num_connections() >= 2, what="image_proc subscribing image_raw")
        cls.results = []
        for x, z in SPOOLS:
            info = df.camera_info_msg(d=D)
            raw_pose = cls.raw.send(df.image_msg(raw_frame(df.draw_spool(x, z)), "mono8"), info)
            stamp = raw_pose.header.stamp
            wait_until(lambda: stamp in cls.rect_poses, what="/rect/spool_pose stamped %s" % stamp)
            with cls.lock:
                cls.results.append((x, z, raw_pose, cls.rect_poses[stamp]))

    @classmethod
    def on_rect_pose(cls, msg):
        with cls.lock:
            cls.rect_poses[msg.header.stamp] = msg

    @classmethod
    def on_log(cls, msg):
        if msg.name == "/camera_manager":
            with cls.lock:
                cls.manager_log.append(msg)

    def test_both_streams_give_the_truth(self):
        for x, z, raw, rect in self.results:
            for name, pose in (("image_raw (K, D)", raw), ("image_rect (P)", rect)):
                why = "%s, spool at x %.2f z %.2f: depth %.4f yaw %.3f deg" % (
                    name, x, z, pose.distance, math.degrees(pose.yaw))
                self.assertTrue(pose.detected, why)
                self.assertAlmostEqual(pose.distance, z, delta=DEPTH_TOLERANCE * z, msg=why)
                self.assertAlmostEqual(pose.yaw, math.atan2(x, z), delta=BEARING_TOLERANCE, msg=why)

    def test_rectified_and_raw_agree(self):
        for x, z, raw, rect in self.results:
            why = "spool at x %.2f z %.2f: raw %.4f m %.3f deg, rect %.4f m %.3f deg" % (
                x, z, raw.distance, math.degrees(raw.yaw), rect.distance, math.degrees(rect.yaw))
            rospy.loginfo(why)
            self.assertAlmostEqual(rect.distance, raw.distance, delta=DEPTH_TOLERANCE * z, msg=why)
            self.assertAlmostEqual(rect.yaw, raw.yaw, delta=BEARING_TOLERANCE, msg=why)

    def test_the_ignored_distortion_is_said_once_and_only_for_image_rect(self):
        with self.lock:
            warnings = [m.msg for m in self.manager_log if m.level == Log.WARN and "not applied again" in m.msg]
        self.assertEqual(len(warnings), 1, warnings)
        self.assertIn("/camera/image_rect", warnings[0])
        self.assertIn("read with P", warnings[0])
        self.assertIn("rectified:=false", warnings[0])
        self.assertFalse(self.raw.log_lines(Log.WARN, "not applied again"))


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "image_proc_rectify", ImageProcRectifyTest)
