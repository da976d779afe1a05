"""Test-side plumbing shared by the rostest nodes: publish frames to the detector, wait for the
SpoolPose of each one (matched by header stamp) and collect what the detector logged.

Waits are bounded in wall-clock time only so that a broken node fails the test instead of
hanging it; no assertion depends on timing.
"""
import subprocess
import threading
import time

import roslib.packages
import rospy
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image

from spool_vision.msg import SpoolPose

TIMEOUT = 30.0  # s of wall time


def wait_until(condition, timeout=TIMEOUT, what="condition"):
    deadline = time.time() + timeout
    while not condition():
        if time.time() > deadline or rospy.is_shutdown():
            raise AssertionError("timed out waiting for " + what)
        time.sleep(0.01)


class DetectorClient(object):
    def __init__(self, node_name="/spool_detector", image_topic="/camera/image_raw",
                 info_topic="/camera/camera_info", publish=True, publish_info=True, image_type=Image,
                 pose_topic="/spool_pose"):
        self.node_name = node_name
        self._lock = threading.Lock()
        self._poses = {}
        self.logs = []
        self._next_stamp = 1000
        self.pose_sub = rospy.Subscriber(pose_topic, SpoolPose, self._on_pose, queue_size=100)
        self.log_sub = rospy.Subscriber("/rosout", Log, self._on_log, queue_size=1000)
        self.info_pub = None
        if publish:
            self.image_pub = rospy.Publisher(image_topic, image_type, queue_size=10)
        if publish and publish_info:
            self.info_pub = rospy.Publisher(info_topic, CameraInfo, queue_size=10)

    def _on_pose(self, msg):
        with self._lock:
            self._poses[msg.header.stamp] = msg

    def _on_log(self, msg):
        if msg.name == self.node_name:
            with self._lock:
                self.logs.append(msg)

    def connect(self, publish=True):
        """Waits until the detector listens to us and we listen to it (poses and its log). A
        detector with use_camera_info false does not subscribe camera_info: make the client with
        publish_info=False."""
        wait_until(lambda: self.pose_sub.get_num_connections() > 0, what="/spool_pose publisher")
        wait_until(lambda: self.node_name in self._log_publishers(), what="the detector's /rosout")
        if publish:
            wait_until(lambda: self.image_pub.get_num_connections() > 0, what="image subscriber")
        if publish and self.info_pub is not None:
            wait_until(lambda: self.info_pub.get_num_connections() > 0, what="camera_info subscriber")

    def _log_publishers(self):
        return [c.callerid_pub for c in self.log_sub.impl.connections
                if hasattr(c, "callerid_pub")]

    def send(self, image, info=None, frame_id="test_camera"):
        """Publishes camera_info (if given) then the image (Image or CompressedImage, as the client
        was made); returns the SpoolPose for the image.
        A detector with use_camera_info true (the default) answers only images sent with info."""
        stamp = rospy.Time(self._next_stamp)
        self._next_stamp += 1
        image.header.stamp = stamp
        image.header.frame_id = frame_id
        if info is not None:
            info.header = image.header
            self.info_pub.publish(info)
        self.image_pub.publish(image)
        return self.pose_for(stamp)

    def pose_for(self, stamp, timeout=TIMEOUT):
        wait_until(lambda: stamp in self._poses, timeout, "SpoolPose stamped %s" % stamp)
        with self._lock:
            return self._poses[stamp]

    def poses(self):
        with self._lock:
            return dict(self._poses)

    def log_lines(self, level, containing=""):
        with self._lock:
            return [m.msg for m in self.logs if m.level == level and containing in m.msg]


class StampedMessages(object):
    """The messages of one of the detector's stamped outputs (~pose, ~marker) by header stamp:
    each carries the header of the image it was made from."""

    def __init__(self, topic, msg_type):
        self._lock = threading.Lock()
        self._msgs = {}
        self.sub = rospy.Subscriber(topic, msg_type, self._on_msg, queue_size=100)

    def _on_msg(self, msg):
        with self._lock:
            self._msgs[msg.header.stamp] = msg

    def connect(self):
        wait_until(lambda: self.sub.get_num_connections() > 0, what=self.sub.name + " publisher")

    def get(self, stamp, timeout=TIMEOUT):
        wait_until(lambda: self.has(stamp), timeout, "%s stamped %s" % (self.sub.name, stamp))
        with self._lock:
            return self._msgs[stamp]

    def has(self, stamp):
        with self._lock:
            return stamp in self._msgs


def assert_refuses(test, node, param, value, *expected):
    """Starts `node` of this package with private `param`:=`value` and asserts it stops at once with
    exit code 1 and a message holding each of `expected`."""
    binary = roslib.packages.find_node("spool_vision", node)[0]
    try:
        r = subprocess.run([binary, "__name:=bad_" + param, "_%s:=%s" % (param, value)], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, timeout=TIMEOUT, universal_newlines=True)
    except subprocess.TimeoutExpired:
        test.fail("%s kept running with %s %s" % (node, param, value))
    test.assertEqual(r.returncode, 1, r.stdout)
    for text in expected:
        test.assertIn(text, r.stdout)
