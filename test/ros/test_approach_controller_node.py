#!/usr/bin/python3
"""rostest: spool_approach_controller driven through its topics. The test plays the detector
(SpoolPose at 10 Hz) and the robot (odom), sends an ApproachAndInsert goal and checks the
commands: a bore ahead and to the left turns the robot left (REP 103: angular.z > 0) and drives it
forward; a bore lower than the puller lowers the lift; `aligned` while coasting is never acted on;
nor is a pose that disagrees with the odometry; a pose that comes before the odometry of its stamp
waits for it; `aligned` on a fused frame publishes `insert` and
ends the goal "inserted". A bad parameter
stops the node at start-up naming the key."""
import math
import threading
import unittest

import actionlib
import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import Empty, Float64

from pose_harness import assert_refuses
from spool_vision.msg import ApproachAndInsertAction, ApproachAndInsertGoal, SpoolPose

TIMEOUT = 30.0


class ApproachControllerNode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("approach_controller_test")
        cls.poses = rospy.Publisher("spool_pose", SpoolPose, queue_size=10)
        cls.odom = rospy.Publisher("odom", Odometry, queue_size=10)
        cls.lock = threading.Lock()
        cls.twists, cls.lifts, cls.inserts = [], [], []
        cls.subscribers = [rospy.Subscriber("cmd_vel", Twist, lambda m: cls.record(cls.twists, m)),
                           rospy.Subscriber("lift_velocity", Float64, lambda m: cls.record(cls.lifts, m)),
                           rospy.Subscriber("insert", Empty, lambda m: cls.record(cls.inserts, m))]
        cls.client = actionlib.SimpleActionClient("approach_and_insert", ApproachAndInsertAction)
        assert cls.client.wait_for_server(rospy.Duration(TIMEOUT)), "no approach_and_insert server"

    @classmethod
    def record(cls, store, message):
        with cls.lock:
            store.append(message)

    @staticmethod
    def pose(stamp, x=0.0, y=0.06, z=1.0, aligned=False, state=SpoolPose.TRACK_TRACKING):
        """A bore at (x, y, z) in the camera frame, its axis along the optical axis."""
        pose = SpoolPose()
        pose.header.stamp = stamp
        pose.header.frame_id = "camera_optical_frame"
        pose.detected = True
        pose.hole_detected = True
        pose.aligned = aligned
        pose.track_state = state
        pose.position.x, pose.position.y, pose.position.z = x, y, z
        pose.axis.x, pose.axis.y, pose.axis.z = 0.0, 0.0, 1.0
        return pose

    @staticmethod
    def odometry(stamp, forward=0.0, left=0.0):
        """The robot `forward` and `left` (m) of where it started, heading unchanged."""
        odom = Odometry()
        odom.header.stamp = stamp
        odom.pose.pose.position.x, odom.pose.pose.position.y = forward, left
        odom.pose.pose.orientation.w = 1.0
        return odom

    def play(self, frames, forward=0.0, left=0.0, **bore):
        """`frames` poses 0.1 s apart (`bore`: pose()'s keywords), each with an odom message at the
        same stamp (the controller checks the poses against that motion)."""
        for _ in range(frames):
            stamp = rospy.Time.now()
            self.odom.publish(self.odometry(stamp, forward, left))
            self.poses.publish(self.pose(stamp, **bore))
            rospy.sleep(0.1)

    def wait_for(self, store, count):
        deadline = rospy.Time.now() + rospy.Duration(TIMEOUT)
        while rospy.Time.now() < deadline:
            with self.lock:
                if len(store) >= count:
                    return list(store)
            rospy.sleep(0.05)
        self.fail("only %d messages" % len(store))

    def until(self, condition, what):
        deadline = rospy.Time.now() + rospy.Duration(TIMEOUT)
        while not condition():
            if rospy.Time.now() > deadline:
                self.fail("timed out waiting for " + what)
            rospy.sleep(0.05)

    def test_approach_then_insert(self):
        # Every connection made and the goal accepted before the first pose (a loaded machine
        # takes its time over each).
        self.until(lambda: self.poses.get_num_connections() > 0 and self.odom.get_num_connections() > 0,
                   "the node's subscriptions")
        self.until(lambda: all(s.get_num_connections() > 0 for s in self.subscribers), "the node's publishers")
        self.client.send_goal(ApproachAndInsertGoal())
        self.until(lambda: self.client.get_state() == actionlib.GoalStatus.ACTIVE, "the goal to be active")
        # The bore 1 m ahead, 5 cm left and 1 cm lower than the puller.
        self.play(5, x=-0.05, y=0.07)
        twists = self.wait_for(self.twists, 5)
        self.assertGreater(twists[-1].linear.x, 0.0)
        self.assertGreater(twists[-1].angular.z, 0.0, "the bore is left: turn left")
        lifts = self.wait_for(self.lifts, 5)
        self.assertLess(lifts[-1].data, 0.0, "the bore is lower: lift down")
        self.assertEqual(self.client.get_state(), actionlib.GoalStatus.ACTIVE)
        # A pose that comes before the odometry of its stamp waits for it: no command until then.
        with self.lock:
            before = len(self.twists)
        stamp = rospy.Time.now()
        self.poses.publish(self.pose(stamp, x=-0.05, y=0.07))
        rospy.sleep(0.4)
        with self.lock:
            self.assertEqual(len(self.twists), before, "a pose newer than every odometry waits for its own")
        self.odom.publish(self.odometry(stamp))
        self.wait_for(self.twists, before + 1)
        # The robot has driven 44 cm on and 5 cm left: the same bore now at the standoff, straight
        # ahead. Aligned on coasting frames (the tracker's prediction) is not acted on.
        at_standoff = dict(z=0.56, aligned=True, forward=0.44, left=0.05)
        self.play(3, state=SpoolPose.TRACK_COASTING, **at_standoff)
        rospy.sleep(0.3)
        with self.lock:
            self.assertEqual(len(self.inserts), 0)
        # A bore 44 cm nearer while the odometry says the robot has not moved (a circle too big):
        # not inserted on.
        self.play(1, z=0.56, aligned=True)
        rospy.sleep(0.3)
        with self.lock:
            self.assertEqual(len(self.inserts), 0)
        # Aligned on a fused frame: the push and the goal's end.
        self.play(1, **at_standoff)
        self.wait_for(self.inserts, 1)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(TIMEOUT)))
        self.assertEqual(self.client.get_state(), actionlib.GoalStatus.SUCCEEDED)
        self.assertEqual(self.client.get_result().outcome, "inserted")
        self.assertTrue(math.isfinite(self.client.get_result().time))

    def test_a_bad_parameter_stops_the_node_naming_it(self):
        assert_refuses(self, "spool_approach_controller", "lookahead", "0.0", "lookahead",
                       "config/approach_controller.yaml")

if __name__ == "__main__":
    rostest.rosrun("spool_vision", "approach_controller", ApproachControllerNode)
