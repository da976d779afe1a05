#!/usr/bin/python3
"""Simple drawn spool frames for the ROS tests: a dark 35 cm flange disc on a lighter
background with a bright 3.6 cm hole at its centre, seen by an ideal 640x480 camera (f = 800 px).

As a program it writes the approach sequence (110 -> 51 cm, sideways error shrinking to zero,
aligned in the last frames) in the renderer's layout: frame_%05d.png, frame_%05d.json (ground
truth) and camera_info.yaml.
"""
import json
import math
import os
import sys

import cv2
import numpy as np

WIDTH, HEIGHT = 640, 480
FOCAL = 800.0
CX, CY = (WIDTH - 1) / 2.0, (HEIGHT - 1) / 2.0
FLANGE_RADIUS = 0.175  # m
HOLE_RADIUS = 0.018  # m
PULLER_BELOW_CAMERA = 0.06  # m: the spool axis is 6 cm below the camera
SHIFT = 4  # fixed-point bits for sub-pixel circle centres


def draw_spool(x, z, background=170, flange=35, hole=235):
    """Grey frame of a spool whose centre is x m right of and 6 cm below the camera, z m ahead."""
    image = np.full((HEIGHT, WIDTH), background, np.uint8)
    u = CX + FOCAL * x / z
    v = CY + FOCAL * PULLER_BELOW_CAMERA / z
    centre = (int(round(u * (1 << SHIFT))), int(round(v * (1 << SHIFT))))
    for radius, shade in ((FLANGE_RADIUS, flange), (HOLE_RADIUS, hole)):
        r = int(round(FOCAL * radius / z * (1 << SHIFT)))
        cv2.circle(image, centre, r, int(shade), -1, cv2.LINE_AA, SHIFT)
    return image


def truth(x, z, aligned_max_yaw=math.radians(0.25), window=(0.5, 0.6), clearance=0.0025):
    """distance is the depth z of the bore's front centre (DESIGN §5), range its Euclidean
    distance. The drawn spool faces the camera (its axis along the optical axis, on the puller's
    level), so the puller clears the bore at both ends when its sideways miss x is within t_f."""
    yaw = math.atan2(x, z)
    return {"distance": z, "range": math.sqrt(x * x + PULLER_BELOW_CAMERA ** 2 + z * z), "yaw": yaw,
            "aligned": abs(yaw) <= aligned_max_yaw and abs(x) <= clearance and window[0] <= z <= window[1]}


def approach_poses(count=16):
    """(x, z) per frame: 110 -> 51 cm deep (the last frame inside the insertion window, not on its
    edge); the 5 cm sideways error is gone 5 frames before the end."""
    poses = []
    for i in range(count):
        z = 1.10 - 0.59 * i / (count - 1)
        x = 0.05 * max(0.0, 1.0 - i / (count - 5.0))
        poses.append((x, z))
    return poses


def camera_info_yaml():
    k = [FOCAL, 0.0, CX, 0.0, FOCAL, CY, 0.0, 0.0, 1.0]
    p = [FOCAL, 0.0, CX, 0.0, 0.0, FOCAL, CY, 0.0, 0.0, 0.0, 1.0, 0.0]
    fmt = lambda values: "[" + ", ".join("%g" % v for v in values) + "]"
    return ("image_width: %d\nimage_height: %d\ncamera_name: drawn\n"
            "camera_matrix:\n  rows: 3\n  cols: 3\n  data: %s\n"
            "distortion_model: plumb_bob\n"
            "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [0, 0, 0, 0, 0]\n"
            "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
            "projection_matrix:\n  rows: 3\n  cols: 4\n  data: %s\n") % (WIDTH, HEIGHT, fmt(k), fmt(p))


def image_msg(pixels, encoding):
    """sensor_msgs/Image packed by hand, so the tests need no cv_bridge."""
    from sensor_msgs.msg import Image
    msg = Image()
    msg.height, msg.width = pixels.shape[:2]
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = pixels.strides[0] if pixels.size else 0
    msg.data = pixels.tobytes()
    return msg


def camera_info_msg(calibrated=True, k_focal=FOCAL, p_focal=FOCAL, d=(0.0,) * 5, model="plumb_bob"):
    """The drawing camera's calibration; k_focal, p_focal and d make K, P and D differ from it."""
    from sensor_msgs.msg import CameraInfo
    msg = CameraInfo()
    msg.width, msg.height = WIDTH, HEIGHT
    if calibrated:
        msg.distortion_model = model
        msg.D = list(d)
        msg.K = [k_focal, 0.0, CX, 0.0, k_focal, CY, 0.0, 0.0, 1.0]
        msg.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        msg.P = [p_focal, 0.0, CX, 0.0, 0.0, p_focal, CY, 0.0, 0.0, 0.0, 1.0, 0.0]
    return msg


def write_approach(folder):
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, "camera_info.yaml"), "w") as f:
        f.write(camera_info_yaml())
    for i, (x, z) in enumerate(approach_poses()):
        cv2.imwrite(os.path.join(folder, "frame_%05d.png" % i), draw_spool(x, z))
        with open(os.path.join(folder, "frame_%05d.json" % i), "w") as f:
            json.dump(truth(x, z), f)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: drawn_frames.py OUTPUT_FOLDER")
    write_approach(sys.argv[1])
