#!/usr/bin/python3
"""rostest: the node refuses to start on a bad or unknown private parameter, and says which key
and what it may be. Each case starts the node binary under its own name and expects exit 1."""
import subprocess
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
