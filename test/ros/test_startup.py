#!/usr/bin/python3
"""rostest: the node refuses to start on a bad or unknown private parameter, and says which key
and what it may be. Each case starts the node binary under its own name and expects exit 1."""
import subprocess
import time
import unittest

import roslib.packages
import rospy
import rostest

TIMEOUT = 60.0  # s of wall time, only to bound a node that wrongly keeps running


class StartupTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("startup_test")
        cls.binary = roslib.packages.find_node("spool_vision", "spool_detector")[0]
        cls.count = 0

    def start(self, *params):
        StartupTest.count += 1
        name = "startup_case_%d" % StartupTest.count
        try:
            result = subprocess.run([self.binary, "__name:=" + name] + list(params),
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    timeout=TIMEOUT, universal_newlines=True)
        except subprocess.TimeoutExpired:
            self.fail("node kept running with " + " ".join(params))
        return result.returncode, result.stdout

    def assert_refused(self, params, *expected):
        code, output = self.start(*params)
        self.assertEqual(code, 1, output)
        self.assertIn("refusing to start", output)
        for text in expected:
            self.assertIn(text, output)

    def test_out_of_range_number(self):
        self.assert_refused(["_sensitivity:=1.5"], "'sensitivity'", "[0, 0.99]")

    def test_refusal_says_how_to_fix_it(self):
        name = "startup_case_%d" % (StartupTest.count + 1)
        self.assert_refused(["_sensitivity:=1.5"], "config:=FILE",
                            "rosparam delete /%s/sensitivity" % name)

    def test_a_stale_bad_value_does_not_block_the_launch_file(self):
        # A key left on the server by an earlier `rosrun spool_vision spool_detector _config:=X`
        # (no such parameter; the YAML does not overwrite it): the launch file clears the node's
        # namespace before loading the YAML, so the node starts.
        name = "stale_case"
        rospy.set_param("/%s/config" % name, "/tmp/mine.yaml")
        launch = subprocess.Popen(["roslaunch", "spool_vision", "spool_detector.launch", "name:=" + name],
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
        try:
            deadline = time.time() + TIMEOUT
            while time.time() < deadline and launch.poll() is None:
                if not rospy.has_param("/%s/config" % name) and \
                        "/" + name in subprocess.run(["rosnode", "list"], stdout=subprocess.PIPE,
                                                     universal_newlines=True).stdout.split():
                    break
                time.sleep(0.5)
            self.assertIsNone(launch.poll(), "the node stopped: stale value not cleared")
            self.assertFalse(rospy.has_param("/%s/config" % name))
            self.assertEqual(rospy.get_param("/%s/sensitivity" % name), 0.55)
        finally:
            launch.terminate()
            launch.wait(timeout=30)

    def test_wrong_type(self):
        self.assert_refused(["_max_candidates:=many"], "'max_candidates'", "[1, 64]")

    def test_unknown_choice(self):
        self.assert_refused(["_filter:=bilateral"], "'filter'", "one of gaussian|median")

    def test_unknown_key(self):
        self.assert_refused(["_sensitivty:=0.8"], "'sensitivty'", "unknown parameter")

    def test_inconsistent_keys(self):
        self.assert_refused(["_distance_min:=1.5", "_distance_max:=1.0"], "'distance_max'",
                            "distance_min")

    def test_unavailable_transport(self):
        self.assert_refused(["_image_transport:=no_such_transport"], "'image_transport'",
                            "no_such_transport")

    def test_bad_queue_size(self):
        self.assert_refused(["_queue_size:=0"], "'queue_size'", "[1, 1000]")


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "startup", StartupTest)
