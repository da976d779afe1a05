#!/usr/bin/python3
"""The two ends of scripts/soak.sh, run as separate processes (so that neither's work delays the
other's clock readings):

    soak_stream.py publish SECONDS STAMPS_FILE   30 Hz 640x480 bgr8 frames of a drawn approach
                                                 with camera_info, on /camera/image_raw; writes
                                                 the stamps it published, one a line
    soak_stream.py monitor NODE STAMPS_FILE      every /spool_pose's latency (receive time -
                                                 header stamp), the node's RSS (from /proc,
                                                 each second) and its "Processing" diagnostics
                                                 until STAMPS_FILE appears; then prints the
                                                 figures and PASS or FAIL
"""
import os
import sys
import threading
import time
import xmlrpc.client

import numpy as np
import rosgraph
import rospy

RATE = 30.0
WARM_UP = 60.0  # s: RSS growth counts from here (or a third of a shorter run)
MAX_RSS_GROWTH_KB = 1024


def publish(seconds, stamps_file):
    import cv2
    from sensor_msgs.msg import CameraInfo, Image
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test", "ros"))
    import drawn_frames as df

    rospy.init_node("soak_publisher")
    image_pub = rospy.Publisher("/camera/image_raw", Image, queue_size=30)
    info_pub = rospy.Publisher("/camera/camera_info", CameraInfo, queue_size=30)
    frames = [df.image_msg(cv2.cvtColor(df.draw_spool(x, z), cv2.COLOR_GRAY2BGR), "bgr8")
              for x, z in df.approach_poses()]
    info = df.camera_info_msg()
    deadline = time.time() + 30
    while image_pub.get_num_connections() == 0 or info_pub.get_num_connections() == 0:
        if time.time() > deadline:
            sys.exit("soak: the detector did not subscribe")
        time.sleep(0.1)
    time.sleep(1.0)  # let both connections settle before the first frame
    stamps = []
    rate = rospy.Rate(RATE)
    for i in range(int(seconds * RATE)):
        if rospy.is_shutdown():
            break
        image = frames[i % len(frames)]
        image.header.seq = info.header.seq = i
        image.header.stamp = info.header.stamp = rospy.Time.now()
        image.header.frame_id = info.header.frame_id = "camera_optical_frame"
        info_pub.publish(info)
        image_pub.publish(image)
        stamps.append(image.header.stamp.to_nsec())
        rate.sleep()
    with open(stamps_file + ".tmp", "w") as f:
        f.write("\n".join(str(s) for s in stamps) + "\n")
    os.rename(stamps_file + ".tmp", stamps_file)


def node_pid(node):
    master = rosgraph.Master("/soak_monitor")
    return xmlrpc.client.ServerProxy(master.lookupNode(node)).getPid("/soak_monitor")[2]


def rss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS for pid %d" % pid)


def percentile(values, q):
    return values[min(len(values) - 1, int(q * len(values)))]


def monitor(node, stamps_file):
    from spool_vision.msg import SpoolPose

    rospy.init_node("soak_monitor")
    received = {}
    lock = threading.Lock()

    def on_pose(msg):
        now = time.time()
        with lock:
            received[msg.header.stamp.to_nsec()] = now - msg.header.stamp.to_sec()

    rospy.Subscriber("/spool_pose", SpoolPose, on_pose, queue_size=1000, tcp_nodelay=True)
    # The node's own view: latency (stamp to publication) and processing time per period.
    from diagnostic_msgs.msg import DiagnosticArray
    processing = []  # {key: value} of each "Processing" update with frames

    def on_diagnostics(msg):
        for status in msg.status:
            if status.name == node.lstrip("/") + ": Processing":
                values = {v.key: v.value for v in status.values}
                if int(values.get("Frames", "0")) > 0:
                    with lock:
                        processing.append(values)

    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=100)
    pid = node_pid(node)
    start = time.time()
    rss = []  # (s since start, kB)
    while not os.path.exists(stamps_file):
        rss.append((time.time() - start, rss_kb(pid)))
        time.sleep(1.0)
    time.sleep(2.0)  # the last poses
    rss.append((time.time() - start, rss_kb(pid)))
    with open(stamps_file) as f:
        published = [int(line) for line in f if line.strip()]
    with lock:
        latencies = sorted(received[s] * 1000.0 for s in published if s in received)
        dropped = sum(1 for s in published if s not in received)
    duration = rss[-1][0]
    warm_up = min(WARM_UP, duration / 3.0)
    after = [kb for t, kb in rss if t >= warm_up]
    growth = max(after) - after[0]

    print("soak: %d frames published at %g Hz over %.0f s, %d SpoolPose received" % (
        len(published), RATE, duration, len(latencies)))
    print("dropped frames: %d" % dropped)
    if latencies:
        print("latency ms (stamp to /spool_pose received): p50 %.2f, p99 %.2f, max %.2f" % (
            percentile(latencies, 0.5), percentile(latencies, 0.99), latencies[-1]))
    with lock:
        updates = list(processing)
    for name in ("Latency", "Processing time"):
        keys = [name + " %s (ms)" % q for q in ("p50", "p95", "max")]
        rows = [[float(u[k]) for k in keys] for u in updates if all(k in u for k in keys)]
        if rows:
            print("node diagnostics, %s ms over %d updates: p50 median %.2f, p95 max %.2f, max %.2f" % (
                name.lower(), len(rows), np.median([r[0] for r in rows]), max(r[1] for r in rows),
                max(r[2] for r in rows)))
    print("node RSS: %d kB at start, %d kB at %.0f s, %d kB at the end, growth after %.0f s: %d kB" % (
        rss[0][1], after[0], warm_up, rss[-1][1], warm_up, growth))
    ok = published and dropped == 0 and growth < MAX_RSS_GROWTH_KB
    print("%s (bars: 0 dropped frames, RSS growth < %d kB after %.0f s)" % (
        "PASS" if ok else "FAIL", MAX_RSS_GROWTH_KB, warm_up))
    return 0 if ok else 1


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "publish":
        publish(float(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) == 4 and sys.argv[1] == "monitor":
        sys.exit(monitor(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(__doc__)
