#!/usr/bin/python3
"""Unit tests of scripts/demo_pictures.py, the demo's contact sheet and plot, on made-up
SpoolPose messages and overlays: no ROS master, no node.

    /usr/bin/python3 test/tools/test_demo_pictures.py [--gtest_output=xml:FILE]

Uses the generated spool_vision/SpoolPose when it can be imported (a sourced devel space, as in
catkin run_tests), otherwise a stand-in with the same fields; either way the fields the plot reads
are checked against msg/SpoolPose.msg. The JUnit XML (rosunit) is what scripts/test.sh counts.
"""
import math
import os
import shutil
import sys
import tempfile
import types
import unittest

import cv2
import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import demo_pictures as dp  # noqa: E402

import genpy  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402
from std_msgs.msg import Header  # noqa: E402

try:
    from spool_vision.msg import SpoolPose
except ImportError:  # no devel space sourced: the fields the pictures read, nothing more
    SpoolPose = None

NAN = float("nan")


def pose(index, distance=NAN, detected=False, aligned=False, yaw=NAN, axis_angle=NAN, **extra):
    """A pose of frame `index`, stamped 1 s + index / 10 s (10 Hz, like the demo bag)."""
    header = Header(stamp=genpy.Time(1 + index // 10, (index % 10) * 100000000), frame_id="camera_optical_frame")
    fields = dict(header=header, detected=detected, hole_detected=detected, aligned=aligned,
                  distance=distance, yaw=yaw, axis_angle=axis_angle)
    if SpoolPose is not None and not extra:
        return SpoolPose(**fields)
    fields.update(extra)
    return types.SimpleNamespace(**fields)


def approach(count=20, aligned_from=17):
    """The demo's shape: depth from 1.098 m down by 3.1 cm a frame, aligned from `aligned_from`."""
    return [pose(i, distance=1.098 - 0.031 * i, detected=True, aligned=i >= aligned_from,
                 yaw=math.radians(-5.0 + 0.25 * i), axis_angle=math.radians(0.7)) for i in range(count)]


def uniform(bgr, width=160, height=120):
    return np.full((height, width, 3), bgr, np.uint8)


def image_msg(pixels, encoding, pad=0):
    """A sensor_msgs/Image of `pixels` with `pad` unused bytes at the end of every row."""
    height, width = pixels.shape[:2]
    rows = pixels.reshape(height, -1)
    padded = np.zeros((height, rows.shape[1] + pad), np.uint8)
    padded[:, :rows.shape[1]] = rows
    return Image(height=height, width=width, encoding=encoding, step=padded.shape[1], data=padded.tobytes())


def png_size(path):
    """(width, height) from a PNG file's header; fails on anything that is not a PNG."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise AssertionError("%s is not a PNG" % path)
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot
    return matplotlib.pyplot


class SummaryTest(unittest.TestCase):
    def test_demo_format(self):
        self.assertEqual(dp.summary_line(approach()),
                         "summary: frames 20, detected 20, aligned 3 (frames 17-19, first at 0.571 m)")

    def test_nothing_aligned(self):
        self.assertEqual(dp.summary_line([pose(0), pose(1)]), "summary: frames 2, detected 0, aligned 0")
        self.assertEqual(dp.summary_line([]), "summary: frames 0, detected 0, aligned 0")


class MessageFieldsTest(unittest.TestCase):
    def test_plotted_fields_are_in_the_message(self):
        declared = set()
        with open(os.path.join(ROOT, "msg", "SpoolPose.msg")) as f:
            for line in f:
                words = line.split("#")[0].split()
                if len(words) == 2:
                    declared.add(words[1])
        used = {field for field, _, _ in dp.PLOT_ROWS} | {"header", "detected", "hole_detected", "aligned"}
        self.assertLessEqual(used, declared)
        # The tracker's raw series: raw_distance, told apart by track_state.
        self.assertIn("raw_distance", declared)
        self.assertIn("track_state", declared)


class ImagePixelsTest(unittest.TestCase):
    def test_bgr8_with_padded_rows(self):
        pixels = np.random.RandomState(1).randint(0, 256, (5, 7, 3)).astype(np.uint8)
        np.testing.assert_array_equal(dp.image_pixels(image_msg(pixels, "bgr8", pad=3)), pixels)

    def test_rgb8_and_mono8_become_bgr(self):
        red_rgb = uniform((255, 0, 0), 4, 3)
        self.assertEqual(tuple(dp.image_pixels(image_msg(red_rgb, "rgb8"))[0, 0]), (0, 0, 255))
        grey = np.full((3, 4), 77, np.uint8)
        self.assertEqual(dp.image_pixels(image_msg(grey, "mono8", pad=2)).shape, (3, 4, 3))

    def test_unshowable_encoding_is_none(self):
        self.assertIsNone(dp.image_pixels(image_msg(np.zeros((2, 2, 2), np.uint8), "mono16")))
        self.assertIsNone(dp.image_pixels(Image(encoding="bgr8")))

    def test_thumbnail_keeps_aspect(self):
        self.assertEqual(dp.thumbnail(uniform((1, 2, 3), 640, 480), 200).shape, (150, 200, 3))
        self.assertIsNone(dp.thumbnail(None, 200))


class ContactSheetTest(unittest.TestCase):
    COLOURS = [(200, 50, 50), (50, 50, 200), (50, 200, 200)]

    def sheet(self, poses, overlays, columns=3, width=160):
        return dp.contact_sheet(poses, overlays, dp.summary_line(poses), columns, width)

    def test_size_borders_and_tiles(self):
        poses = approach(count=7, aligned_from=4)
        overlays = [uniform(self.COLOURS[i % 3]) for i in range(7)]
        overlays[2] = None
        sheet = self.sheet(poses, overlays)
        layout = dp.SheetLayout(7, 3, 160, 120)
        self.assertEqual((layout.columns, layout.rows), (3, 3))
        self.assertEqual(sheet.shape, (layout.height, layout.width, 3))
        self.assertEqual(layout.width, 3 * (160 + 2 * layout.border) + 4 * layout.gap)
        for i, p in enumerate(poses):
            x, y = layout.cell(i)
            b = layout.border
            expected = dp.ALIGNED_BGR if p.aligned else dp.BORDER_BGR
            # Every side of the frame: top-left, bottom-right, the middle of the left edge.
            for px, py in ((x, y), (x + 160 + 2 * b - 1, y + 120 + 2 * b - 1), (x + b // 2, y + 60)):
                self.assertEqual(tuple(sheet[py, px]), expected, "frame %d at (%d, %d)" % (i, px, py))
            inner = tuple(sheet[y + b + 2, x + b + 2])
            self.assertEqual(inner, dp.MISSING_BGR if overlays[i] is None else self.COLOURS[i % 3], "tile %d" % i)
        # The whole frame green on aligned tiles only, and a green label ("ALIGNED") under them.
        green = np.all(sheet == dp.ALIGNED_BGR, axis=2)
        b, g, r = (sheet[:, :, c].astype(int) for c in range(3))
        greenish = (g > 100) & (g > 2 * r) & (g > 2 * b)
        frame_area = (160 + 2 * layout.border) * (120 + 2 * layout.border) - 160 * 120
        for i, p in enumerate(poses):
            x, y = layout.cell(i)
            frame_h = 120 + 2 * layout.border
            self.assertEqual(int(green[y:y + frame_h, x:x + layout.cell_w].sum()), frame_area if p.aligned else 0)
            label = greenish[y + frame_h:y + layout.cell_h, x:x + layout.cell_w]
            self.assertEqual(bool(label.sum() > 20), p.aligned, "label of frame %d" % i)

    def test_full_size_overlays_are_scaled_to_the_tile(self):
        poses = approach(count=2)
        sheet = self.sheet(poses, [uniform((10, 20, 30), 640, 480), uniform((10, 20, 30), 640, 480)], width=200)
        layout = dp.SheetLayout(2, 3, 200, 150)
        self.assertEqual(sheet.shape, (layout.height, layout.width, 3))
        x, y = layout.cell(1)
        self.assertEqual(tuple(sheet[y + layout.border + 75, x + layout.border + 100]), (10, 20, 30))

    def test_nothing_detected_and_no_overlays(self):
        poses = [pose(i) for i in range(4)]
        sheet = self.sheet(poses, [None] * 4, columns=5)
        layout = dp.SheetLayout(4, 5, 160, 120)  # 4:3 when no overlay gives the aspect
        self.assertEqual(sheet.shape, (layout.height, layout.width, 3))
        self.assertEqual(layout.columns, 4)
        self.assertFalse(np.all(sheet == dp.ALIGNED_BGR, axis=2).any())
        self.assertEqual(dp.metres(NAN), "-- m")
        self.assertEqual(dp.frame_state(poses[0]), "no spool")

    def test_empty_stream(self):
        self.assertEqual(self.sheet([], []).shape[2], 3)

    def test_overlay_count_must_match(self):
        with self.assertRaises(ValueError):
            self.sheet(approach(count=2), [None])


class SaveSheetTest(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="demo_pictures_")

    def tearDown(self):
        shutil.rmtree(self.folder)

    def test_palette_keeps_the_aligned_colour(self):
        poses = approach(count=6, aligned_from=5)
        grey_ramp = np.tile(np.linspace(0, 255, 160).astype(np.uint8)[None, :, None], (120, 1, 3))
        sheet = dp.contact_sheet(poses, [grey_ramp] * 6, "t", 3, 160)
        for colours in (0, 16):
            path = os.path.join(self.folder, "sub", "sheet%d.png" % colours)
            dp.save_sheet(path, sheet, colours)
            self.assertEqual(png_size(path), (sheet.shape[1], sheet.shape[0]))
            read = cv2.imread(path)
            x, y = dp.SheetLayout(6, 3, 160, 120).cell(5)
            self.assertEqual(tuple(read[y, x]), dp.ALIGNED_BGR)
            self.assertEqual(tuple(read[y, dp.SheetLayout(6, 3, 160, 120).cell(4)[0]]), dp.BORDER_BGR)
        with self.assertRaises(ValueError):
            dp.save_sheet(os.path.join(self.folder, "x.png"), sheet, 4)


class PlotTest(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="demo_pictures_")

    def tearDown(self):
        shutil.rmtree(self.folder)

    def test_series_in_plot_units(self):
        series = dp.plot_series(approach(count=3))
        self.assertEqual([round(t, 6) for t in series["t"]], [0.0, 0.1, 0.2])
        labels = [label for label, _, _ in series["rows"]]
        self.assertEqual(labels, ["depth [m]", "bearing yaw [deg]", "axis angle [deg]", "aligned"])
        depth, yaw, axis, aligned = (raw for _, raw, _ in series["rows"])
        self.assertAlmostEqual(depth[1], 1.067)
        self.assertAlmostEqual(yaw[0], -5.0)
        self.assertAlmostEqual(axis[2], 0.7)
        self.assertEqual(aligned, [0.0, 0.0, 0.0])
        self.assertTrue(all(filtered is None for _, _, filtered in series["rows"]))

    def test_one_series_without_the_tracker(self):
        # A node with track false sends raw_distance = distance and TRACK_OFF: nothing to filter.
        untracked = [pose(i, distance=1.0 - 0.01 * i, detected=True, raw_distance=1.0 - 0.01 * i, track_state=0)
                     for i in range(3)]
        self.assertTrue(all(filtered is None for _, _, filtered in dp.plot_series(untracked)["rows"]))

    def test_filtered_series_when_the_message_has_raw_fields(self):
        tracked = [pose(i, distance=1.0 - 0.01 * i, detected=True, yaw=0.0, axis_angle=0.0,
                        raw_distance=1.02 - 0.01 * i, raw_yaw=0.01, raw_axis_angle=0.0, track_state=2) for i in range(3)]
        rows = {label: (raw, filtered) for label, raw, filtered in dp.plot_series(tracked)["rows"]}
        raw, filtered = rows["depth [m]"]
        self.assertAlmostEqual(raw[0], 1.02)
        self.assertAlmostEqual(filtered[0], 1.0)
        self.assertAlmostEqual(rows["bearing yaw [deg]"][0][0], math.degrees(0.01))
        self.assertIsNone(rows["aligned"][1])  # no raw_aligned: aligned stays one series

    def plot(self, poses, name):
        path = os.path.join(self.folder, "new", name)
        dp.approach_plot(poses, path, dp.summary_line(poses), pyplot())
        self.assertEqual(png_size(path), (int(dp.PLOT_WIDTH_IN * dp.PLOT_DPI), int(dp.PLOT_HEIGHT_IN * dp.PLOT_DPI)))
        self.assertFalse(pyplot().get_fignums(), "the figure was not closed")
        return path

    def test_png_of_the_expected_size(self):
        self.plot(approach(), "approach.png")

    def test_nan_gaps_and_nothing_detected(self):
        gaps = approach(count=8)
        gaps[3] = pose(3)
        gaps[4] = pose(4)
        self.assertTrue(math.isnan(dp.plot_series(gaps)["rows"][0][1][3]))
        self.plot(gaps, "gaps.png")
        self.plot([pose(i) for i in range(5)], "nothing.png")
        self.plot([pose(0, distance=0.5, detected=True, aligned=True)], "one_frame.png")
        self.plot([], "empty.png")

    def test_filtered_plot(self):
        tracked = [pose(i, distance=1.0 - 0.01 * i, detected=True, aligned=i > 2, yaw=0.0, axis_angle=0.0,
                        raw_distance=1.02 - 0.01 * i, raw_yaw=0.01, raw_axis_angle=0.0, track_state=2) for i in range(5)]
        self.plot(tracked, "tracked.png")


if __name__ == "__main__":
    try:
        import rosunit
    except ImportError:
        unittest.main()
    else:
        # Writes the JUnit XML that --gtest_output=xml:FILE names (default: under ROS_HOME).
        rosunit.unitrun("spool_vision", "demo_pictures", "__main__")
