#!/usr/bin/python3
"""Print spool_vision/SpoolPose messages as `rostopic echo` does, then a one-line summary.

Waits for one pose per image in the given bag; with --resume it first waits until it is
subscribed and then un-pauses a `rosbag play --pause` player, so no pose is missed.
"""
import argparse
import sys
import time

import rosbag
import rospy
from std_srvs.srv import SetBool

from spool_vision.msg import SpoolPose


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bag", required=True, help="the bag being replayed")
    parser.add_argument("--image-topic", default="/camera/image_raw")
    parser.add_argument("--topic", default="/spool_pose")
    parser.add_argument("--resume", help="pause_playback service of a paused rosbag player")
    parser.add_argument("--timeout", type=float, default=120.0, help="wall-clock seconds")
    args = parser.parse_args(rospy.myargv()[1:])

    with rosbag.Bag(args.bag) as bag:
        expected = bag.get_message_count(args.image_topic)
    if expected == 0:
        sys.exit("echo_poses: no %s messages in %s" % (args.image_topic, args.bag))

    rospy.init_node("echo_poses", anonymous=True)
    poses = []
    sub = rospy.Subscriber(args.topic, SpoolPose, poses.append, queue_size=1000)
    deadline = time.time() + args.timeout
    if args.resume:
        while sub.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
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
    aligned = [i for i, p in enumerate(received) if p.aligned]
    line = "summary: frames %d, detected %d, aligned %d" % (
        len(received), sum(p.detected for p in received), len(aligned))
    if aligned:
        line += " (frames %d-%d, first at %.3f m)" % (aligned[0], aligned[-1], received[aligned[0]].distance)
    print(line)
    if printed < expected:
        sys.exit("echo_poses: only %d of %d poses arrived" % (printed, expected))


if __name__ == "__main__":
    main()
