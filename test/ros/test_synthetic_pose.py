#!/usr/bin/python3
"""rostest: drawn frames with a calibrated camera_info go through the node; every SpoolPose
field is checked against the geometry the frame was drawn with."""
import math
import unittest

import dynamic_reconfigure.client
import numpy as np
import rospy
import rostest
from sensor_msgs.msg import Image

import drawn_frames as df
from pose_harness import DetectorClient, wait_until


def expected_reference_y(distance):
    return df.CY + df.FOCAL * df.PULLER_BELOW_CAMERA / distance


class SyntheticPoseTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("synthetic_pose_test")
        # Inside a nodelet manager the detector logs under the manager's name.
        cls.client = DetectorClient(node_name=rospy.get_param("~log_node", "/spool_detector"))
        cls.client.connect()

    def send(self, pixels, encoding="mono8"):
        return self.client.send(df.image_msg(pixels, encoding), df.camera_info_msg())

    def test_centred_spool(self):
        pose = self.send(df.draw_spool(0.0, 0.8))
        truth = df.truth(0.0, 0.8)
        self.assertEqual(pose.header.frame_id, "test_camera")
        self.assertTrue(pose.detected)
        self.assertTrue(pose.hole_detected)
        self.assertAlmostEqual(pose.distance, truth["distance"], delta=0.02 * truth["distance"])
        self.assertLess(abs(pose.yaw), math.radians(0.2))
        self.assertLess(abs(pose.lateral_offset), 0.003)
        self.assertAlmostEqual(pose.tolerance, 0.0025, places=6)
        self.assertAlmostEqual(pose.flange_x, df.CX, delta=1.0)
        self.assertAlmostEqual(pose.flange_y, expected_reference_y(0.8), delta=1.0)
        self.assertAlmostEqual(pose.flange_radius, df.FOCAL * df.FLANGE_RADIUS / 0.8, delta=3.0)
        self.assertAlmostEqual(pose.hole_x, df.CX, delta=1.0)
        self.assertAlmostEqual(pose.hole_radius, df.FOCAL * df.HOLE_RADIUS / 0.8, delta=2.0)
        self.assertAlmostEqual(pose.reference_x, df.CX, delta=0.5)
        self.assertAlmostEqual(pose.reference_y, expected_reference_y(truth["distance"]), delta=0.5)
        self.assertTrue(pose.overlapped)
        self.assertFalse(pose.aligned, "80 cm is outside the 50-60 cm insertion window")
        self.assertGreater(pose.confidence, 0.5)
        self.assertLessEqual(pose.confidence, 1.0)

    def test_spool_right_of_the_puller_has_positive_yaw(self):
        pose = self.send(df.draw_spool(0.10, 0.8))
        truth = df.truth(0.10, 0.8)
        self.assertTrue(pose.detected)
        self.assertAlmostEqual(pose.yaw, truth["yaw"], delta=math.radians(0.3))
        self.assertGreater(pose.yaw, 0.0)
        self.assertAlmostEqual(pose.lateral_offset, pose.distance * math.tan(pose.yaw), places=6)
        self.assertAlmostEqual(pose.distance, truth["distance"], delta=0.02 * truth["distance"])
        self.assertFalse(pose.overlapped)
        self.assertFalse(pose.aligned)

    def test_centred_spool_in_the_insertion_window_is_aligned(self):
        pose = self.send(df.draw_spool(0.0, 0.55))
        self.assertTrue(pose.detected)
        self.assertTrue(pose.overlapped)
        self.assertTrue(pose.aligned)

    def test_no_spool_gives_nan_not_stale_values(self):
        self.send(df.draw_spool(0.0, 0.8))  # a detection first: nothing of it may remain
        pose = self.send(np.full((df.HEIGHT, df.WIDTH), 170, np.uint8))
        self.assertFalse(pose.detected)
        self.assertFalse(pose.hole_detected)
        self.assertFalse(pose.overlapped)
        self.assertFalse(pose.aligned)
        for field in ("distance", "yaw", "lateral_offset", "flange_x", "flange_y", "flange_radius",
                      "hole_x", "hole_y", "hole_radius"):
            self.assertTrue(math.isnan(getattr(pose, field)), field)
        self.assertEqual(pose.confidence, 0.0)

    def test_colour_and_16_bit_encodings_give_the_same_answer(self):
        grey = df.draw_spool(0.05, 0.9)
        reference = self.send(grey)
        colour = np.dstack([grey, grey, grey])
        for encoding, pixels in (("bgr8", colour), ("rgb8", colour),
                                 ("bgra8", np.dstack([colour, np.full_like(grey, 255)])),
                                 ("mono16", grey.astype(np.uint16) * 257)):
            pose = self.send(np.ascontiguousarray(pixels), encoding)
            self.assertTrue(pose.detected, encoding)
            self.assertAlmostEqual(pose.distance, reference.distance, delta=0.005 * reference.distance,
                                   msg=encoding)
            self.assertAlmostEqual(pose.yaw, reference.yaw, delta=math.radians(0.05), msg=encoding)

    def test_webcam_driver_encodings_give_the_same_answer(self):
        # YUYV (the C270's stream, as drivers name it), UYVY, a Bayer mosaic, 16-bit colour and
        # big-endian mono16: each frame of the same grey scene must give the same pose.
        grey = df.draw_spool(0.05, 0.9)
        reference = self.send(grey)
        chroma = np.full_like(grey, 128)
        frames = {
            "yuv422_yuy2": (np.dstack([grey, chroma]).reshape(grey.shape[0], -1), False),
            "yuv422": (np.dstack([chroma, grey]).reshape(grey.shape[0], -1), False),
            "bayer_rggb8": (grey, False),
            "bayer_bggr8": (grey, False),
            "bayer_gbrg8": (grey, False),
            "bayer_grbg8": (grey, False),
            "bayer_rggb16": (grey.astype(np.uint16) * 257, False),
            "bgr16": (np.dstack([grey, grey, grey]).astype(np.uint16) * 257, False),
            "mono16": (grey.astype(">u2") * 257, True),
        }
        for encoding, (pixels, big_endian) in frames.items():
            msg = df.image_msg(np.ascontiguousarray(pixels), encoding)
            msg.width = grey.shape[1]
            msg.is_bigendian = 1 if big_endian else 0
            pose = self.client.send(msg, df.camera_info_msg())
            self.assertTrue(pose.detected, encoding)
            self.assertAlmostEqual(pose.distance, reference.distance, delta=0.005 * reference.distance,
                                   msg=encoding)
            self.assertAlmostEqual(pose.yaw, reference.yaw, delta=math.radians(0.05), msg=encoding)

    def test_reconfigure_changes_the_detector_and_rejects_inconsistent_values(self):
        client = dynamic_reconfigure.client.Client("/spool_detector", timeout=30)
        try:
            # Widening the insertion window to 90 cm makes a centred spool at 80 cm aligned.
            config = client.update_configuration({"aligned_distance_max": 0.9})
            self.assertAlmostEqual(config["aligned_distance_max"], 0.9)
            self.assertTrue(self.send(df.draw_spool(0.0, 0.8)).aligned)
            # A near end beyond the far end is refused and the settings in force come back.
            config = client.update_configuration({"aligned_distance_min": 1.5})
            self.assertAlmostEqual(config["aligned_distance_min"], 0.5)
            self.assertTrue(self.send(df.draw_spool(0.0, 0.8)).aligned)
        finally:
            client.update_configuration({"aligned_distance_min": 0.5, "aligned_distance_max": 0.6})
        self.assertFalse(self.send(df.draw_spool(0.0, 0.8)).aligned)

    def test_debug_image_shows_the_overlay(self):
        received = []
        sub = rospy.Subscriber("/spool_detector/debug_image", Image, received.append, queue_size=5)
        try:
            wait_until(lambda: sub.get_num_connections() > 0, what="debug_image publisher")
            # The node sees the subscriber slightly after we see the connection: resend until
            # an overlay for one of our frames arrives.
            def got_overlay():
                self.send(df.draw_spool(0.0, 0.8))
                return len(received) > 0
            wait_until(got_overlay, what="a debug image")
        finally:
            sub.unregister()
        overlay = received[0]
        self.assertEqual(overlay.encoding, "bgr8")
        self.assertEqual((overlay.width, overlay.height), (df.WIDTH, df.HEIGHT))
        pixels = np.frombuffer(overlay.data, np.uint8).reshape(overlay.height, overlay.width, 3)
        b, g, r = (pixels[:, :, i].astype(int) for i in range(3))
        red = (r > 200) & (g < 80) & (b < 80)
        blue = (b > 200) & (g < 80) & (r < 80)
        green = (g > 200) & (r < 80) & (b < 80)
        # The flange rim is red all the way round, the hole rim blue, the reference cross green.
        self.assertGreater(int(red.sum()), 500)
        self.assertGreater(int(blue.sum()), 50)
        self.assertGreater(int(green.sum()), 10)


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "synthetic_pose", SyntheticPoseTest)
