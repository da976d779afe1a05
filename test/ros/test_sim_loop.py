#!/usr/bin/python3
"""rostest: one closed-loop trial end to end through the real topics (launch/sim.launch). The
world (spool_sim_world) renders what the robot's camera sees, the detector node tracks the spool,
the controller node drives on its SpoolPose and pushes; the world judges the push on the
renderer's geometry. Asserts the puller went in (the misses within t_f at both ends of the bore),
the action ended "inserted", and spool_sim, running the same trial in one process, ends the same
way at the same frame: the ROS path adds no latency, drops no frame and changes no decision. The
launch's defaults are spool_sim's second config (config/forklift_mount.yaml) and its
--target-hint (the world publishes the slot in odom, the detector turns it through TF)."""
import json
import math
import os
import subprocess
import sys
import unittest

import roslib.packages
import rospy
import rostest
from geometry_msgs.msg import PointStamped

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import run_sim_trial  # noqa: E402 (the launch's own trial runner, from scripts/)
from pose_harness import assert_refuses  # noqa: E402

TIMEOUT = 600.0  # wall s: a trial is 6-60 s of frames at 640x480


class SimLoop(unittest.TestCase):
    def test_trial_inserts_as_spool_sim_does(self):
        rospy.init_node("sim_loop_test")
        seed = rospy.get_param("~seed")
        outcome, result = run_sim_trial.run_trial(TIMEOUT)
        print(run_sim_trial.describe(outcome, result), flush=True)
        self.assertEqual(outcome.seed, seed)
        self.assertEqual(outcome.outcome, "inserted")
        self.assertTrue(0.0 < outcome.tolerance < 0.01)
        self.assertLessEqual(max(outcome.front_miss, outcome.back_miss), outcome.tolerance)
        self.assertIsNotNone(result, "the action gave no result")
        self.assertEqual(result.outcome, "inserted")

        spool_sim = roslib.packages.find_node("spool_vision", "spool_sim")
        self.assertTrue(spool_sim, "spool_sim is not built")
        hint = rospy.wait_for_message("/target_hint", PointStamped, timeout=10.0)  # latched
        self.assertEqual(hint.header.frame_id, "odom")
        config = os.path.join(roslib.packages.get_pkg_dir("spool_vision"), "config")
        run = subprocess.run([spool_sim[0], "--trials", "1", "--seed", str(seed),
                              "--config", os.path.join(config, "default.yaml"),
                              "--config", os.path.join(config, "forklift_mount.yaml"),
                              "--target-hint", str(rospy.get_param("/spool_detector/target_hint_radius"))],
                             capture_output=True, text=True, timeout=TIMEOUT, check=True)
        trial = json.loads(run.stdout.splitlines()[0])
        self.assertEqual(trial["outcome"], outcome.outcome)
        self.assertEqual(trial["retries"], result.retries)
        self.assertEqual(trial["steps"], outcome.steps)
        self.assertAlmostEqual(trial["time_to_insert"], outcome.time_to_insert, places=6)
        self.assertAlmostEqual(trial["front_miss_mm"], 1e3 * outcome.front_miss, delta=0.05)
        self.assertAlmostEqual(trial["back_miss_mm"], 1e3 * outcome.back_miss, delta=0.05)
        self.assertFalse(math.isnan(outcome.time_to_insert))

    def test_a_bad_parameter_stops_the_world_naming_it(self):
        assert_refuses(self, "spool_sim_world", "rate", "0.0", "'rate': 0 is outside [1, 100]", "config/sim_world.yaml")

if __name__ == "__main__":
    rostest.rosrun("spool_vision", "sim_loop", SimLoop)
