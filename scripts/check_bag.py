#!/usr/bin/python3
"""Checks that a bag holds the image topic the detector will read, before a replay starts.

    check_bag.py BAG IMAGE_TOPIC CAMERA_INFO_TOPIC

IMAGE_TOPIC must be in the bag as sensor_msgs/Image, or as sensor_msgs/CompressedImage when it
ends in /compressed. On success prints that type (replay.launch stores it as a parameter) and
exits 0; a missing CAMERA_INFO_TOPIC only gets a warning (the detector says what it does then).
Otherwise prints one error naming the topics the bag holds, with the launch args that would
replay the image topics among them, and exits 1.
"""
import sys

IMAGE = "sensor_msgs/Image"
COMPRESSED = "sensor_msgs/CompressedImage"
COMPRESSED_SUFFIX = "/compressed"


def replay_args(topic, msg_type):
    """The replay.launch args that read `topic` (a topic of an image type)."""
    if msg_type == COMPRESSED and topic.endswith(COMPRESSED_SUFFIX):
        return "image:=%s image_transport:=compressed" % topic[:-len(COMPRESSED_SUFFIX)]
    return "image:=" + topic


def problem(topics, image_topic):
    """None when the bag has the image topic with the right type, else the error text."""
    wanted = COMPRESSED if image_topic.endswith(COMPRESSED_SUFFIX) else IMAGE
    if topics.get(image_topic) == wanted:
        return None
    found = ", ".join("%s (%s)" % (t, topics[t]) for t in sorted(topics)) or "none"
    usable = [replay_args(t, m) for t, m in sorted(topics.items()) if m in (IMAGE, COMPRESSED)]
    hint = ("; replay one of its image topics with " + " or ".join(usable)) if usable else \
        "; it holds no sensor_msgs/Image or sensor_msgs/CompressedImage topic"
    if image_topic in topics:
        what = "has %s as %s, not %s" % (image_topic, topics[image_topic], wanted)
    else:
        what = "has no %s topic %s" % (wanted, image_topic)
    return "the bag %s for the detector. Topics in the bag: %s%s" % (what, found, hint)


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: check_bag.py BAG IMAGE_TOPIC CAMERA_INFO_TOPIC")
    path, image_topic, info_topic = sys.argv[1:]
    import rosbag  # here: the usage above needs no ROS
    try:
        with rosbag.Bag(path) as bag:
            topics = {t: info.msg_type for t, info in bag.get_type_and_topic_info().topics.items()}
    except (IOError, OSError, rosbag.ROSBagException) as e:
        sys.exit("check_bag: cannot read the bag %s: %s" % (path, e))
    error = problem(topics, image_topic)
    if error:
        sys.exit("check_bag: %s: %s" % (path, error))
    if info_topic not in topics:
        sys.stderr.write("check_bag: warning: %s has no %s; the detector measures nothing without camera_info "
                         "unless use_camera_info is false\n" % (path, info_topic))
    sys.stdout.write(topics[image_topic])  # the parameter's value: no newline


if __name__ == "__main__":
    main()
