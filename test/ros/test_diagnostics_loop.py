#!/usr/bin/python3
"""rostest: diagnostics of a looping bag under sim time. While the bag plays, over several loops
(the clock goes back at each), "Frame rate" and "Frame age" stay OK and every frame gets its
SpoolPose; paused, both say STALE ("no frames"), never "Frequency too high"; resumed, OK again."""
import collections
import threading
import time
import unittest

import rosbag
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Clock
from std_srvs.srv import SetBool

from spool_vision.msg import SpoolPose
from pose_harness import TIMEOUT, wait_until

NODE = "spool_detector"
LOOPS = 4


class DiagnosticsLoopTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("diagnostics_loop_test")
        with rosbag.Bag(rospy.get_param("~bag")) as bag:
            cls.stamps = sorted({m.header.stamp for _, m, _ in bag.read_messages(topics=["/camera/image_raw"])})
        cls.lock = threading.Lock()
        cls.statuses = []  # (wall time, status) of the node's stream statuses
        cls.processing = []  # its "Processing" statuses
        cls.pose_counts = collections.Counter()
        cls.clock_jumps = 0
        cls.last_clock = None
        subscribers = [rospy.Subscriber("/diagnostics", DiagnosticArray, cls.on_diagnostics, queue_size=100),
                       rospy.Subscriber("/spool_pose", SpoolPose, cls.on_pose, queue_size=100),
                       rospy.Subscriber("/clock", Clock, cls.on_clock, queue_size=1000)]
        for sub in subscribers:
            wait_until(lambda: sub.get_num_connections() > 0, what=sub.name + " publisher")
        rospy.wait_for_service("/player/pause_playback", timeout=TIMEOUT)
        cls.pause = rospy.ServiceProxy("/player/pause_playback", SetBool)

    @classmethod
    def on_diagnostics(cls, msg):
        with cls.lock:
            for status in msg.status:
                if status.name.startswith(NODE + ": Frame"):
                    cls.statuses.append((time.time(), status))
                elif status.name == NODE + ": Processing":
                    cls.processing.append(status)

    @classmethod
    def on_pose(cls, msg):
        with cls.lock:
            cls.pose_counts[msg.header.stamp] += 1

    @classmethod
    def on_clock(cls, msg):
        with cls.lock:
            if cls.last_clock is not None and msg.clock < cls.last_clock:
                cls.clock_jumps += 1
            cls.last_clock = msg.clock

    def statuses_since(self, since, name):
        with self.lock:
            return [s for t, s in self.statuses if t >= since and s.name == NODE + ": " + name]

    def wait_for_statuses(self, since, name, count):
        wait_until(lambda: len(self.statuses_since(since, name)) >= count, what="%d %s statuses" % (count, name))
        return self.statuses_since(since, name)

    def describe(self, statuses):
        return "\n".join("%d %s" % (s.level, s.message) for s in statuses)

    def assert_stale(self, since):
        for name in ("Frame rate", "Frame age"):
            statuses = self.wait_for_statuses(since, name, 2)
            self.assertTrue(all(s.level == DiagnosticStatus.STALE and s.message == "no frames" for s in statuses),
                            name + ":\n" + self.describe(statuses))

    def assert_latency_reported(self):
        # Each update with frames gives the latency (stamp to SpoolPose publication, in the bag's
        # time) and the processing time per frame as 0 <= p50 <= p95 <= max, under a second even
        # on a loaded 2-core machine.
        with self.lock:
            updates = [{v.key: v.value for v in s.values} for s in self.processing]
        with_frames = [u for u in updates if int(u.get("Frames", "0")) > 0]
        self.assertGreaterEqual(len(with_frames), LOOPS, updates)
        for name in ("Latency", "Processing time"):
            # An update in which the stamps or the clock went back (a loop's start) reports no
            # latency; the others do.
            reported = [u for u in with_frames if name + " p50 (ms)" in u]
            self.assertGreaterEqual(len(reported), 2, "%s: %s" % (name, with_frames))
            for u in reported:
                p50, p95, top = (float(u[name + " %s (ms)" % q]) for q in ("p50", "p95", "max"))
                self.assertTrue(0.0 <= p50 <= p95 <= top < 1000.0, "%s: %s" % (name, u))
        self.assertTrue(all("Processing time p50 (ms)" in u for u in with_frames), with_frames)

    def test_loops_and_pauses(self):
        # Paused from the start: no frames yet.
        self.assert_stale(time.time() + 0.1)

        self.pause(False)
        wait_until(lambda: self.clock_jumps >= LOOPS, timeout=TIMEOUT + 3 * LOOPS, what="%d loops" % LOOPS)
        self.pause(True)
        paused_at = time.time()
        # Every update while playing (from the first with frames), the loop boundaries included:
        # OK, and a measured rate where the window was not just restarted.
        with self.lock:
            statuses = [s for t, s in self.statuses if t < paused_at]
        first = next(i for i, s in enumerate(statuses) if s.level != DiagnosticStatus.STALE)
        rate = [s for s in statuses[first:] if s.name.endswith("Frame rate")]
        age = [s for s in statuses[first:] if s.name.endswith("Frame age")]
        rospy.loginfo("statuses while playing:\n%s", self.describe(rate + age))
        self.assertGreaterEqual(len(rate), LOOPS)
        self.assertTrue(all(s.level == DiagnosticStatus.OK for s in rate + age),
                        "\n" + self.describe(rate + age))
        self.assertTrue(any(s.message == "Desired frequency met" for s in rate), self.describe(rate))
        self.assertTrue(any("clock went back" in s.message or "stamps went back" in s.message for s in rate),
                        self.describe(rate))

        # Paused: stale, not "too high" (the clock stands still while updates go on).
        self.assert_stale(paused_at + 1.5)
        # Every frame of every loop got its SpoolPose: each stamp as often as the others (the
        # loop in progress at the pause counts once less for the frames it had not reached).
        with self.lock:
            counts = [self.pose_counts[s] for s in self.stamps]
            stray = set(self.pose_counts) - set(self.stamps)
        self.assertFalse(stray, "poses with stamps not in the bag")
        self.assertGreaterEqual(min(counts), LOOPS, counts)
        self.assertLessEqual(max(counts) - min(counts), 1, counts)
        self.assertEqual(counts, sorted(counts, reverse=True), counts)

        self.assert_latency_reported()

        resumed_at = time.time()
        self.pause(False)
        rate = self.wait_for_statuses(resumed_at + 0.1, "Frame rate", 3)
        self.assertTrue(all(s.level == DiagnosticStatus.OK for s in rate[1:]), self.describe(rate))


if __name__ == "__main__":
    rostest.rosrun("spool_vision", "diagnostics_loop", DiagnosticsLoopTest)
