#!/usr/bin/python3
"""Un-pause a `rosbag play --pause` player once a node has subscribed to the given topics.

demo.launch rviz:=true runs it so that RViz, which starts slower than the detector the player
waits for, sees the replay (the marker, pose and spool TF are not latched; the bag lasts 2 s).
After --timeout wall-clock seconds without them it resumes anyway, with a warning.
  resume_when_subscribed.py --node /rviz --topics /tf /spool_detector/marker [--service S]
"""
import argparse
import time

import rosgraph
import rospy
from std_srvs.srv import SetBool


def missing_topics(master, node, topics):
    _, subscribers, _ = master.getSystemState()
    subscribed = {topic for topic, nodes in subscribers if node in nodes}
    return [t for t in topics if t not in subscribed]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--node", required=True, help="the subscriber to wait for, e.g. /rviz")
    parser.add_argument("--topics", nargs="+", required=True, help="resolved topic names")
    parser.add_argument("--service", default="/player/pause_playback", help="the player's pause service")
    parser.add_argument("--timeout", type=float, default=60.0, help="wall-clock seconds")
    args = parser.parse_args(rospy.myargv()[1:])

    rospy.init_node("resume_when_subscribed", anonymous=True)
    master = rosgraph.Master(rospy.get_name())
    deadline = time.time() + args.timeout
    missing = args.topics
    while time.time() < deadline and not rospy.is_shutdown():
        missing = missing_topics(master, args.node, args.topics)
        if not missing:
            break
        time.sleep(0.1)
    if missing:
        rospy.logwarn("%s has not subscribed to %s after %.0f s; resuming the replay anyway",
                      args.node, " ".join(missing), args.timeout)
    rospy.wait_for_service(args.service, timeout=max(5.0, deadline - time.time()))
    rospy.ServiceProxy(args.service, SetBool)(False)
    rospy.loginfo("replay resumed")


if __name__ == "__main__":
    main()
