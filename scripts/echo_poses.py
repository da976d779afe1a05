#!/usr/bin/python3
"""Print spool_vision/SpoolPose messages as `rostopic echo` does, then a one-line summary.

Waits for one pose per image in the given bag; with --resume it first waits until it is
subscribed and then un-pauses a `rosbag play --pause` player, so no pose is missed. With
--pictures DIR it also subscribes the detector's overlay (which the node only draws while someone
subscribes) and writes DIR/approach_sheet.png, every frame's overlay labelled with its index, depth
and state (aligned frames framed green), and DIR/approach_plot.png, depth, bearing, spool axis
angle and aligned against time; it prints their paths before the summary, which stays the last line.
"""
import argparse
import os
import sys
import time

import rosbag
import rospy
from sensor_msgs.msg import Image
from std_srvs.srv import SetBool

from spool_vision.msg import SpoolPose

# demo_pictures.py lies beside this file; run through catkin's devel relay, sys.path[0] is the
# relay's folder, but __file__ is still this source file.
sys.path.insert(1, os.path.dirname(os.path.realpath(__file__)))
import demo_pictures  # noqa: E402


class Overlays(object):
    """The overlays received, keyed by stamp and already shrunk to the sheet's tile width."""

    def __init__(self, tile_width):
        self.tile_width = tile_width
        self.by_stamp = {}

    def add(self, msg):
        self.by_stamp[demo_pictures.stamp_key(msg.header)] = demo_pictures.thumbnail(
            demo_pictures.image_pixels(msg), self.tile_width)

    def missing(self, poses):
        return sum(demo_pictures.stamp_key(p.header) not in self.by_stamp for p in poses)

    def for_poses(self, poses):
        return [self.by_stamp.get(demo_pictures.stamp_key(p.header)) for p in poses]


def write_pictures(args, poses, overlays, title):
    """The sheet and the plot; prints their paths. Returns False when one could not be written
    (said on stderr): the pictures are a by-product, the summary still comes, and comes last."""
    ok = True
    sheet_path = os.path.join(args.pictures, "approach_sheet.png")
    plot_path = os.path.join(args.pictures, "approach_plot.png")
    try:
        sheet = demo_pictures.contact_sheet(poses, overlays.for_poses(poses), title, args.columns, args.tile_width)
        demo_pictures.save_sheet(sheet_path, sheet, args.colours)
        print("contact sheet: %s" % sheet_path)
    except Exception as e:  # noqa: BLE001 (cv2.error, PIL's errors, OSError alike)
        print("echo_poses: no contact sheet: %s" % e, file=sys.stderr)
        ok = False
    try:
        import matplotlib
        matplotlib.use("Agg")  # no display needed
        import matplotlib.pyplot as pyplot
        demo_pictures.approach_plot(poses, plot_path, title, pyplot)
        print("plot: %s" % plot_path)
    except ImportError as e:
        print("echo_poses: no plot, matplotlib is missing (%s): install python3-matplotlib" % e, file=sys.stderr)
        ok = False
    except Exception as e:  # noqa: BLE001
        print("echo_poses: no plot: %s" % e, file=sys.stderr)
        ok = False
    return ok


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bag", required=True, help="the bag being replayed")
    parser.add_argument("--image-topic", default="/camera/image_raw")
    parser.add_argument("--topic", default="/spool_pose")
    parser.add_argument("--resume", help="pause_playback service of a paused rosbag player")
    parser.add_argument("--timeout", type=float, default=120.0, help="wall-clock seconds")
    parser.add_argument("--pictures", metavar="DIR", help="write approach_sheet.png and approach_plot.png here")
    parser.add_argument("--overlay-topic", default="/spool_detector/debug_image")
    parser.add_argument("--columns", type=int, default=5, help="tiles per row of the contact sheet")
    parser.add_argument("--tile-width", type=int, default=320, help="width of a sheet tile [px]")
    parser.add_argument("--colours", type=int, default=0,
                        help="save the sheet with this many palette colours, 8-256 (0: full colour)")
    args = parser.parse_args(rospy.myargv()[1:])
    if args.columns < 1 or args.tile_width < 16 or not (args.colours == 0 or 8 <= args.colours <= 256):
        parser.error("--columns must be >= 1, --tile-width >= 16, --colours 0 or 8-256")

    with rosbag.Bag(args.bag) as bag:
        expected = bag.get_message_count(args.image_topic)
    if expected == 0:
        sys.exit("echo_poses: no %s messages in %s" % (args.image_topic, args.bag))

    rospy.init_node("echo_poses", anonymous=True)
    poses = []
    sub = rospy.Subscriber(args.topic, SpoolPose, poses.append, queue_size=1000)
    overlays = Overlays(args.tile_width)
    overlay_sub = None
    if args.pictures:
        # A 640x480 overlay is 900 kB: a large receive buffer keeps rospy from falling behind.
        overlay_sub = rospy.Subscriber(args.overlay_topic, Image, overlays.add, queue_size=1000, buff_size=2 ** 24)
    deadline = time.time() + args.timeout
    if args.resume:
        while sub.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
        if overlay_sub is not None:
            # The node draws overlays only for a subscriber: connected before the first frame. The
            # node advertises both topics at once, so a few seconds more mean it has no overlay.
            overlay_deadline = min(deadline, time.time() + 10.0)
            while overlay_sub.get_num_connections() == 0 and time.time() < overlay_deadline:
                time.sleep(0.05)
            if overlay_sub.get_num_connections() == 0:
                print("echo_poses: nobody publishes %s: the sheet will have no overlays" % args.overlay_topic,
                      file=sys.stderr)
        rospy.wait_for_service(args.resume, timeout=max(1.0, deadline - time.time()))
        rospy.ServiceProxy(args.resume, SetBool)(False)

    printed = 0
    while printed < expected and time.time() < deadline and not rospy.is_shutdown():
        while printed < len(poses):
            print(poses[printed])
            print("---")
            printed += 1
        time.sleep(0.02)
    sys.stdout.flush()

    received = poses[:printed]
    line = demo_pictures.summary_line(received)
    pictures_ok = True
    if args.pictures:
        # The node publishes a frame's overlay just after its pose: give the last ones a moment.
        settle = min(deadline, time.time() + 2.0)
        while overlays.missing(received) and time.time() < settle and not rospy.is_shutdown():
            time.sleep(0.02)
        overlay_sub.unregister()
        if overlays.missing(received):
            print("echo_poses: %d of %d frames without an overlay (their tiles say so)"
                  % (overlays.missing(received), len(received)), file=sys.stderr)
        pictures_ok = write_pictures(args, received, overlays, line)
    print(line)
    sys.stdout.flush()
    if printed < expected:
        sys.exit("echo_poses: only %d of %d poses arrived" % (printed, expected))
    if not pictures_ok:
        sys.exit(1)


if __name__ == "__main__":
    main()
