#!/usr/bin/python3
"""Writes the detector_fuzz seed inputs (test/fuzz/corpus/detector_fuzz/): tiny frames of a
drawn spool (dark flange, bright bore on a grey shelf) behind the header detector_fuzz.cpp reads
(width, height as little-endian 16-bit, format, camera kind, parameter set, layout, camera bytes)."""
import pathlib
import struct
import sys

import numpy as np

HEADER = 16
FORMATS = {"mono8": 0, "mono16": 1, "bgr8": 2, "rgb8": 3, "bgra8": 4, "rgba8": 5}
CHANNELS = {"mono8": 1, "mono16": 1, "bgr8": 3, "rgb8": 3, "bgra8": 4, "rgba8": 4}


def spool(width, height, flange, hole):
    y, x = np.mgrid[0:height, 0:width]
    d = np.hypot(x - (width - 1) / 2, y - (height - 1) / 2)
    gray = np.full((height, width), 170, np.uint8)
    gray[d <= flange] = 35
    gray[d <= hole] = 235
    return gray


def seed(name, width, height, fmt, camera, params, layout, gray, out):
    head = struct.pack("<HHBBBB", width, height, FORMATS[fmt], camera, params, layout)
    head += bytes([128] * (HEADER - len(head)))  # camera bytes at their middle: nominal values
    if fmt == "mono16":
        pixels = (gray.astype(np.uint16) * 257).astype("<u2").tobytes()
    else:
        pixels = np.repeat(gray[:, :, None], CHANNELS[fmt], axis=2).tobytes()
    (out / name).write_bytes(head + pixels)


def main():
    out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "test/fuzz/corpus/detector_fuzz")
    out.mkdir(parents=True, exist_ok=True)
    seed("spool_64x48_bgr8", 64, 48, "bgr8", 0, 0, 0, spool(64, 48, 20, 2.5), out)
    seed("spool_80x60_mono8_distorted", 80, 60, "mono8", 2, 0, 0, spool(80, 60, 25, 3), out)
    seed("spool_48x36_mono16_thesis", 48, 36, "mono16", 1, 1, 1, spool(48, 36, 15, 2), out)
    seed("spool_33x47_rgba8_view", 33, 47, "rgba8", 3, 3, 1, spool(33, 47, 12, 2), out)
    seed("blank_31x32_mono8", 31, 32, "mono8", 4, 2, 0, np.full((32, 31), 128, np.uint8), out)


if __name__ == "__main__":
    main()
