#!/usr/bin/python3
"""Write a rosbag with image and camera_info topics from a folder of rendered frames.

The folder holds frame_%05d.png (as spool_render writes them) and camera_info.yaml (ROS
camera-calibration format). Frame i is stamped start + i / rate; its camera_info carries the
same header and is stored a microsecond earlier, so that `rosbag play` publishes the
calibration before the image it belongs to. With --format jpeg or png the frames are stored as
sensor_msgs/CompressedImage on IMAGE_TOPIC/compressed (image_transport's naming), as
compressed_image_transport writes them.
"""
import argparse
import glob
import os
import sys

import cv2
import rosbag
import rospy
import yaml
from sensor_msgs.msg import CameraInfo, CompressedImage, Image


def load_camera_info(path):
    with open(path) as f:
        calib = yaml.safe_load(f)
    info = CameraInfo()
    info.width = int(calib["image_width"])
    info.height = int(calib["image_height"])
    info.distortion_model = calib.get("distortion_model", "plumb_bob")
    info.D = [float(v) for v in calib.get("distortion_coefficients", {}).get("data", [])]
    info.K = [float(v) for v in calib["camera_matrix"]["data"]]
    info.R = [float(v) for v in calib.get("rectification_matrix", {}).get(
        "data", [1, 0, 0, 0, 1, 0, 0, 0, 1])]
    info.P = [float(v) for v in calib.get("projection_matrix", {}).get(
        "data", info.K[0:3] + [0.0] + info.K[3:6] + [0.0] + info.K[6:9] + [0.0])]
    return info


def to_image_msg(pixels, encoding):
    # Packed by hand (no cv_bridge): rows are contiguous, so step = width * bytes per pixel.
    msg = Image()
    msg.height, msg.width = pixels.shape[:2]
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = pixels.strides[0]
    msg.data = pixels.tobytes()
    return msg


def to_compressed_msg(pixels, encoding, image_format, quality):
    # compressed_image_transport's format string: "<encoding>; <jpeg|png> compressed <encoding>".
    if encoding == "rgb8":
        pixels = cv2.cvtColor(pixels, cv2.COLOR_RGB2BGR)  # the codecs take BGR
    params = [cv2.IMWRITE_JPEG_QUALITY, quality] if image_format == "jpeg" else []
    ok, data = cv2.imencode("." + image_format, pixels, params)
    if not ok:
        raise IOError("cannot encode a frame as " + image_format)
    msg = CompressedImage()
    msg.format = "%s; %s compressed %s" % (encoding, image_format, encoding)
    msg.data = data.tobytes()
    return msg


def read_frame(path, encoding):
    if encoding == "mono8":
        pixels = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    else:
        pixels = cv2.imread(path, cv2.IMREAD_COLOR)
    if pixels is None:
        raise IOError("cannot read image " + path)
    if encoding == "rgb8":
        pixels = cv2.cvtColor(pixels, cv2.COLOR_BGR2RGB)
    return pixels


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", help="folder with frame_%%05d.png and camera_info.yaml")
    parser.add_argument("bag", help="output bag file")
    parser.add_argument("--rate", type=float, default=10.0, help="frames per second (default 10)")
    parser.add_argument("--start", type=float, default=1.0,
                        help="stamp of the first frame in seconds (default 1.0)")
    parser.add_argument("--image-topic", default="/camera/image_raw")
    parser.add_argument("--info-topic", default="/camera/camera_info")
    parser.add_argument("--frame-id", default="camera_optical_frame")
    parser.add_argument("--camera-info", help="calibration YAML (default FRAMES/camera_info.yaml)")
    parser.add_argument("--encoding", choices=["mono8", "bgr8", "rgb8"], default="bgr8")
    parser.add_argument("--compression", choices=["none", "bz2", "lz4"], default="lz4")
    parser.add_argument("--format", choices=["raw", "jpeg", "png"], default="raw",
                        help="raw: sensor_msgs/Image on IMAGE_TOPIC; jpeg, png: CompressedImage on "
                             "IMAGE_TOPIC/compressed")
    parser.add_argument("--quality", type=int, default=90, help="JPEG quality (default 90)")
    args = parser.parse_args()

    if args.rate <= 0:
        parser.error("--rate must be positive")
    frames = sorted(glob.glob(os.path.join(args.frames, "frame_*.png")))
    if not frames:
        parser.error("no frame_*.png in " + args.frames)
    info_path = args.camera_info or os.path.join(args.frames, "camera_info.yaml")
    if not os.path.isfile(info_path):
        parser.error("no camera calibration at " + info_path)
    info = load_camera_info(info_path)

    image_topic = args.image_topic if args.format == "raw" else args.image_topic + "/compressed"
    with rosbag.Bag(args.bag, "w", compression=args.compression) as bag:
        for i, path in enumerate(frames):
            pixels = read_frame(path, args.encoding)
            height, width = pixels.shape[:2]
            if (width, height) != (info.width, info.height):
                sys.exit("%s is %dx%d but the calibration is for %dx%d" % (
                    path, width, height, info.width, info.height))
            if args.format == "raw":
                image = to_image_msg(pixels, args.encoding)
            else:
                image = to_compressed_msg(pixels, args.encoding, args.format, args.quality)
            stamp = rospy.Time.from_sec(args.start + i / args.rate)
            image.header.seq = info.header.seq = i
            image.header.stamp = info.header.stamp = stamp
            image.header.frame_id = info.header.frame_id = args.frame_id
            bag.write(args.info_topic, info, stamp - rospy.Duration(0, 1000))
            bag.write(image_topic, image, stamp)
    print("frames_to_bag: %d frames at %g Hz on %s -> %s" % (len(frames), args.rate, image_topic, args.bag))


if __name__ == "__main__":
    main()
