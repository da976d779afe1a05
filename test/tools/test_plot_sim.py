#!/usr/bin/python3
"""Unit tests of scripts/plot_sim.py (spool_sim's trajectories from above) on made-up trials.

    /usr/bin/python3 test/tools/test_plot_sim.py [--gtest_output=xml:FILE]
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import cv2

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", ".."))
SCRIPT = os.path.join(ROOT, "scripts", "plot_sim.py")


def trial(seed, outcome, end_x):
    """A straight run from 1.1 m to 0.56 m ending end_x beside the axis."""
    steps = [{"x": 0.1 + (end_x - 0.1) * i / 20.0, "depth": 1.1 - 0.54 * i / 20.0} for i in range(21)]
    return {"seed": seed, "outcome": outcome, "trajectory": steps}


class PlotSim(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()

    def tearDown(self):
        shutil.rmtree(self.dir)

    def run_script(self, lines, *extra):
        source = os.path.join(self.dir, "trials.jsonl")
        with open(source, "w") as f:
            f.write("\n".join(lines) + "\n")
        return subprocess.run([sys.executable, SCRIPT, source] + list(extra), capture_output=True, text=True)

    def test_draws_every_outcome(self):
        lines = [json.dumps(trial(1, "inserted", 0.0)), json.dumps(trial(2, "timeout", 0.004)),
                 json.dumps(trial(3, "collision", -0.003))]
        r = self.run_script(lines)
        self.assertEqual(r.returncode, 0, r.stderr)
        png = os.path.join(self.dir, "trajectories.png")
        image = cv2.imread(png)
        self.assertIsNotNone(image)
        self.assertEqual(image.shape[:2], (600, 1200))
        # The three outcomes' colours are drawn (matplotlib's tab:green, tab:orange, tab:red, BGR,
        # at the paths' alpha of 0.7 on white).
        for bgr in ((44, 160, 44), (14, 127, 255), (40, 39, 214)):
            seen = [0.7 * c + 0.3 * 255 for c in bgr]
            close = (abs(image.astype(float) - seen).sum(axis=2) < 30).sum()
            self.assertGreater(close, 100, bgr)

    def test_a_bad_file_is_refused_with_its_line(self):
        r = self.run_script([json.dumps(trial(1, "inserted", 0.0)), '{"seed": 2}'])
        self.assertEqual(r.returncode, 2)
        self.assertIn("line 2", r.stderr)
        r = self.run_script([json.dumps(trial(1, "exploded", 0.0))])
        self.assertEqual(r.returncode, 2)
        self.assertIn("exploded", r.stderr)


if __name__ == "__main__":
    try:
        import rosunit
    except ImportError:
        unittest.main()
    else:
        rosunit.unitrun("spool_vision", "plot_sim", "__main__")
