#!/usr/bin/python3
"""Check RViz's window in `demo.launch rviz:=true` from a screenshot, once the replay is over.

Run by scripts/rviz_demo_check.sh (which starts the X server, roscore and the launch). Waits until
the bag player has come and gone, then grabs the X display until these hold (or --settle ends):
  marker       the 3D view shows the marker's copper (src/ros/pose_conversion.cpp's colour) in one
               blob of a spool's size near the middle of the view (not only in the overlay panel)
  pose_axes    the pose's red and green axes at the spool
  tf_frames    the TF display's frame names at the spool (spool) and away from it (camera_link)
  camera_axes  red, green and blue axes away from the spool (camera_link, the Camera display)
  displays     no display in the Displays panel shows RViz's error or warning colour
and then checks the launch log and the run's node logs for errors and that RViz is still up.
Saves the last screenshot (--out), writes one JUnit testcase per check (--junit); exit 1 on a
failure.
"""
import argparse
import collections
import glob
import re
import signal
import time
import xml.etree.ElementTree as ET

import numpy as np
import rosgraph
from PIL import ImageGrab

BACKGROUND = (48, 48, 48)  # demo.rviz's Background Color
MARKER_RGB = (0.72, 0.45, 0.2)  # spoolMarker() in src/ros/pose_conversion.cpp
STATUS_ERROR = (192, 32, 32)  # rviz's StatusProperty colours as drawn in the Displays panel
STATUS_WARN = (192, 128, 0)


def hue(rgb):
    """Hue in degrees of a colour with r >= g >= b (copper's ordering)."""
    r, g, b = rgb
    return 60.0 * (g - b) / (r - b)


def view_box(img):
    """The 3D view: the one large area of demo.rviz's background colour, as (x0, y0, x1, y1)."""
    bg = (np.abs(img - np.array(BACKGROUND)) <= 2).all(axis=2)
    cols = bg.sum(axis=0)
    if cols.max() < 100:
        return None
    xs = np.nonzero(cols >= 0.5 * cols.max())[0]
    rows = bg[:, xs.min():xs.max() + 1].sum(axis=1)
    ys = np.nonzero(rows >= 0.5 * rows.max())[0]
    return xs.min(), ys.min(), xs.max() + 1, ys.max() + 1


def largest_blob(mask, cell=4):
    """Largest 4-connected blob of mask on a grid of cell x cell squares (those at least half
    set): (area in pixels, (cx, cy) centroid, (x0, y0, x1, y1) bounding box) or None."""
    h, w = mask.shape[0] // cell * cell, mask.shape[1] // cell * cell
    cells = mask[:h, :w].reshape(h // cell, cell, w // cell, cell).mean(axis=(1, 3)) >= 0.5
    seen = np.zeros_like(cells)
    best = None
    for start in zip(*np.nonzero(cells)):
        if seen[start]:
            continue
        seen[start] = True
        queue, members = collections.deque([start]), []
        while queue:
            y, x = queue.popleft()
            members.append((y, x))
            for ny, nx in ((y + 1, x), (y - 1, x), (y, x + 1), (y, x - 1)):
                if 0 <= ny < cells.shape[0] and 0 <= nx < cells.shape[1] and cells[ny, nx] and not seen[ny, nx]:
                    seen[ny, nx] = True
                    queue.append((ny, nx))
        if best is None or len(members) > len(best):
            best = members
    if best is None:
        return None
    ys, xs = np.array(best).T * cell
    box = (xs.min(), ys.min(), xs.max() + cell, ys.max() + cell)
    return len(best) * cell * cell, (xs.mean() + cell / 2, ys.mean() + cell / 2), box


def check_screen(img):
    """({check: failure message or None}, [what was measured]) for one screenshot (H x W x 3)."""
    notes = []
    box = view_box(img)
    if box is None:
        msg = "no 3D view (no area of the background colour %s): RViz not drawn?" % (BACKGROUND,)
        return {check: msg for check in ("marker", "pose_axes", "tf_frames", "camera_axes", "displays")}, notes
    x0, y0, x1, y1 = box
    view = img[y0:y1, x0:x1]
    r, g, b = view[..., 0], view[..., 1], view[..., 2]
    vw, vh = x1 - x0, y1 - y0
    result = {}

    # The copper's hue and saturation survive RViz's lighting and the 0.8 alpha over the grey
    # background (the brightness does not).
    copper = (r > g) & (g > b) & (r - b >= 25)
    pixel_hue = 60.0 * (g - b) / np.maximum(r - b, 1)
    copper &= (np.abs(pixel_hue - hue(MARKER_RGB)) <= 8) & ((r - b) >= 0.4 * r)
    blob = largest_blob(copper)
    spool_box = None
    if blob is None:
        result["marker"] = "no copper (hue %.0f deg) pixels in the 3D view %s" % (hue(MARKER_RGB), box)
    else:
        area, (cx, cy), spool_box = blob
        where = (cx / vw, cy / vh)
        if not 0.01 * vw * vh <= area <= 0.4 * vw * vh:
            result["marker"] = "copper blob of %d px in a %dx%d view: not a spool's size" % (area, vw, vh)
        elif not (0.15 <= where[0] <= 0.75 and 0.2 <= where[1] <= 0.8):
            result["marker"] = "copper blob at (%.2f, %.2f) of the view, not near its middle" % where
        else:
            result["marker"] = None
        notes.append("3D view %s, copper blob %d px at (%.2f, %.2f) of it, box %s"
                     % (box, area, where[0], where[1], spool_box))

    # Pixels of the axes' pure colours and of RViz's white frame names (nothing else in the view
    # is white), at the spool (its box grown by a third of its size on each side) and elsewhere.
    kinds = {
        "red": (r >= 150) & (g <= 70) & (b <= 70),
        "green": (g >= 150) & (r <= 70) & (b <= 70),
        "blue": (b >= 150) & (r <= 70) & (g <= 70),
        "white": (r >= 220) & (g >= 220) & (b >= 220),
    }
    if spool_box is None:
        for check in ("pose_axes", "tf_frames", "camera_axes"):
            result[check] = "no spool marker to look beside"
    else:
        sx0, sy0, sx1, sy1 = spool_box
        mx, my = (sx1 - sx0) // 3, (sy1 - sy0) // 3
        near = np.zeros(r.shape, bool)
        near[max(0, sy0 - my):sy1 + my, max(0, sx0 - mx):sx1 + mx] = True
        at = {name: int((m & near).sum()) for name, m in kinds.items()}
        away = {name: int((m & ~near).sum()) for name, m in kinds.items()}
        notes.append("pixels at the spool %s, elsewhere %s" % (at, away))

        def short(counts, wanted, what):
            missing = ["%s %d < %d" % (name, counts[name], least) for name, least in wanted if counts[name] < least]
            return "too few pixels " + what + ": " + ", ".join(missing) if missing else None

        # The pose's axes (0.15 m) at the bore draw about 240 px of red and of green there, the
        # spool TF frame's small axes under them about 70.
        result["pose_axes"] = short(at, (("red", 150), ("green", 150)), "of the pose's axes at the spool")
        # TF: the names "spool" (at the spool, about 60 px) and "camera_link" (about 200 px).
        result["tf_frames"] = short({"spool": at["white"], "camera_link": away["white"]},
                                    (("spool", 30), ("camera_link", 100)), "of the TF frame names")
        # camera_link's TF axes and the Camera display's axes, away from the spool.
        result["camera_axes"] = short(away, (("red", 50), ("green", 50), ("blue", 50)), "of the camera's axes")

    # Displays panel: the white tree left of the 3D view. An errored display's name and icon are
    # drawn in the error colour, a warning in orange; nothing else there has those colours.
    left = img[:, :x0]
    white_rows = (left == 255).all(axis=2).mean(axis=1) >= 0.5
    panel = left[white_rows]
    bad = {name: int((np.abs(panel - np.array(colour)) <= 10).all(axis=-1).sum())
           for name, colour in (("error", STATUS_ERROR), ("warning", STATUS_WARN))}
    notes.append("Displays panel (%d rows): %s-coloured pixels" % (white_rows.sum(), bad))
    if white_rows.sum() < 50:
        result["displays"] = "no Displays panel left of the 3D view"
    elif bad["error"] >= 10 or bad["warning"] >= 10:
        result["displays"] = "Displays panel shows a status in error (%d px) or warning (%d px)" % (
            bad["error"], bad["warning"])
    else:
        result["displays"] = None
    return result, notes


def nodes(master):
    pubs, subs, srvs = master.getSystemState()
    return {n for _, names in pubs + subs + srvs for n in names}


def wait_for_replay(master, player, launch_log, timeout):
    """Until the player node has registered and gone again, having played the whole bag (roslaunch
    says it finished cleanly, not that it was killed); returns a failure message or None."""
    deadline = time.time() + timeout
    while player not in nodes(master):
        if time.time() > deadline:
            return "the player %s never started" % player
        time.sleep(0.2)
    while player in nodes(master):
        if time.time() > deadline:
            return "the replay did not end within %.0f s" % timeout
        time.sleep(0.2)
    finished = re.compile(r"\[%s-\d+\] process has finished cleanly" % re.escape(player.lstrip("/")))
    for _ in range(50):  # roslaunch notices the exit a moment after the node unregisters
        with open(launch_log, errors="replace") as f:
            if finished.search(f.read()):
                return None
        time.sleep(0.1)
    return "the player %s stopped without finishing the bag (see %s)" % (player, launch_log)


def log_errors(launch_log, run_dir):
    """Error lines of roslaunch's output, of the nodes' output and of the run's rosout.log."""
    checks = [(launch_log, re.compile(r"cannot launch node|\bERROR\b|\bFATAL\b|process has died"))]
    node_error = re.compile(r"\[\s*(ERROR|FATAL)\s*\]")  # roscpp's and rospy's console format
    checks += [(path, node_error) for path in sorted(glob.glob(run_dir + "/*-stdout.log"))]
    checks.append((run_dir + "/rosout.log", re.compile(r"^\S+\s+(ERROR|FATAL)\s")))
    lines = []
    for path, pattern in checks:
        try:
            with open(path, errors="replace") as f:
                lines += [path + ": " + line.strip() for line in f if pattern.search(line)]
        except FileNotFoundError:
            lines.append(path + ": missing")
    return lines


def write_junit(path, cases, elapsed):
    suite = ET.Element("testsuite", name="rviz_demo", tests=str(len(cases)),
                       failures=str(sum(1 for m in cases.values() if m)), time="%.1f" % elapsed)
    for name, message in cases.items():
        case = ET.SubElement(suite, "testcase", classname="rviz_demo", name=name)
        if message:
            ET.SubElement(case, "failure", message=message)
    ET.ElementTree(suite).write(path, encoding="unicode", xml_declaration=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--display", required=True, help="X display, e.g. :1")
    parser.add_argument("--launch-log", required=True, help="roslaunch's output")
    parser.add_argument("--log-dir", required=True, help="ROS_LOG_DIR (holds the run's node logs)")
    parser.add_argument("--out", required=True, help="screenshot to write (png)")
    parser.add_argument("--junit", required=True, help="JUnit XML to write")
    parser.add_argument("--player", default="/player")
    parser.add_argument("--rviz", default="/rviz")
    parser.add_argument("--timeout", type=float, default=90.0, help="seconds for the replay to end")
    parser.add_argument("--draw", type=float, default=2.0, help="seconds RViz gets to draw after it")
    parser.add_argument("--settle", type=float, default=15.0, help="seconds to retry the screen checks")
    args = parser.parse_args()
    # Started in the background by a script, which ignores SIGINT there: own_master.sh's cleanup
    # stops it with SIGINT.
    signal.signal(signal.SIGINT, signal.default_int_handler)

    start = time.time()
    master = rosgraph.Master("/rviz_demo_check")
    cases = collections.OrderedDict()
    cases["replay"] = wait_for_replay(master, args.player, args.launch_log, args.timeout)
    time.sleep(args.draw)
    deadline = time.time() + args.settle
    while True:
        shot = ImageGrab.grab(xdisplay=args.display)
        screen, notes = check_screen(np.asarray(shot.convert("RGB")).astype(int))
        if not any(screen.values()) or time.time() > deadline:
            break
        time.sleep(1.0)
    shot.save(args.out)
    for note in notes:
        print("rviz_demo_check: " + note)
    cases.update(screen)

    cases["rviz_running"] = None if args.rviz in nodes(master) else "%s is no longer running" % args.rviz
    run_id = master.getParam("/run_id")
    errors = log_errors(args.launch_log, "%s/%s" % (args.log_dir, run_id))
    # Without the terminal's colour codes, which XML cannot hold.
    cases["logs"] = re.sub(r"\x1b\[[0-9;]*m|[\x00-\x08\x0b-\x1f]", "", "; ".join(errors[:5])) if errors else None

    for name, message in cases.items():
        print("rviz_demo_check: %-12s %s" % (name, "FAILED: " + message if message else "ok"))
    write_junit(args.junit, cases, time.time() - start)
    return 1 if any(cases.values()) else 0


if __name__ == "__main__":
    try:
        raise SystemExit(main())
    except KeyboardInterrupt:
        raise SystemExit("rviz_demo_check: interrupted")
