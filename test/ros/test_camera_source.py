#!/usr/bin/python3
"""rostest: v4l2_camera_node (OpenCV VideoCapture + camera_info_manager) feeding the detector.
No webcam is needed: VideoCapture opens a video file given as the device, so the node is fed an
MJPEG clip of a drawn spool and a calibration file, exactly as a C270 with its YAML would be."""
import os
import shutil
import subprocess
import tempfile
import unittest

import cv2
import roslib.packages
import rospy
import rostest
from sensor_msgs.msg import CameraInfo, Image

import drawn_frames as df
from pose_harness import DetectorClient, wait_until


class CameraSourceTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("camera_source_test")
        cls.folder = tempfile.mkdtemp(prefix="spool_camera_")
        video = os.path.join(cls.folder, "clip.avi")
        writer = cv2.VideoWriter(video, cv2.VideoWriter_fourcc(*"MJPG"), 10, (df.WIDTH, df.HEIGHT))
        frame = cv2.cvtColor(df.draw_spool(0.0, 0.7), cv2.COLOR_GRAY2BGR)
        for _ in range(10):
            writer.write(frame)
        writer.release()
        calibration = os.path.join(cls.folder, "c270.yaml")
        with open(calibration, "w") as f:
            f.write(df.camera_info_yaml())

        cls.images, cls.infos = [], []
        rospy.Subscriber("/camera/image_raw", Image, cls.images.append, queue_size=5)
        rospy.Subscriber("/camera/camera_info", CameraInfo, cls.infos.append, queue_size=5)
        cls.client = DetectorClient(publish=False)
        cls.client.connect(publish=False)

        binary = roslib.packages.find_node("spool_vision", "v4l2_camera_node")[0]
        env = dict(os.environ, ROS_NAMESPACE="/camera")
        cls.camera = subprocess.Popen(
            [binary, "__name:=v4l2_camera", "_device:=" + video, "_fps:=20", "_frame_id:=c270",
             "_camera_info_url:=file://" + calibration], env=env)

    @classmethod
    def tearDownClass(cls):
        cls.camera.terminate()
        cls.camera.wait()
        shutil.rmtree(cls.folder)

    def test_publishes_image_and_calibration_with_one_header(self):
        wait_until(lambda: len(self.images) > 0 and len(self.infos) > 0, what="image_raw and camera_info")
        image = self.images[-1]
        self.assertEqual((image.width, image.height, image.encoding), (df.WIDTH, df.HEIGHT, "bgr8"))
        self.assertEqual(image.header.frame_id, "c270")
        # One header for both: some image's stamp is a camera_info's (the subscribers' queues may
        # each have dropped different messages, so not necessarily the first image's).
        wait_until(lambda: len(self.images) >= 3 and len(self.infos) >= 3, what="three of each")
        stamps = set(i.header.stamp for i in self.infos)
        self.assertTrue(any(i.header.stamp in stamps for i in self.images))
        self.assertAlmostEqual(self.infos[-1].K[0], df.FOCAL)

    def test_detector_measures_the_spool_seen_by_the_camera(self):
        wait_until(lambda: len(self.client.poses()) > 0, what="a SpoolPose")
        pose = list(self.client.poses().values())[-1]
        truth = df.truth(0.0, 0.7)["distance"]
        self.assertTrue(pose.detected)
        self.assertEqual(pose.header.frame_id, "c270")
        self.assertAlmostEqual(pose.distance, truth, delta=0.02 * truth)


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "camera_source", CameraSourceTest)
