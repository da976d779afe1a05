#!/usr/bin/python3
"""Measures the detector's per-frame error model (1-sigma measurement noise) for a tracker.

    measure_error_model.py [--out FILE] [--quick] [--work DIR] [--sizes WxH,...] [--seeds S,...]
                           [--count N] [--count-hd N] [--approach-count N] [--jobs N] [--fresh]
                           [--config FILE] [--bin DIR]

Renders spool_render's main, hard, distorted and approach sets at each size and seed (into
--work, default $SPOOL_WS/error_model, outside the repository; a folder rendered earlier with
the same options by the same spool_render is reused unless --fresh) and runs spool_detect on
each folder twice, with the set's camera_info.yaml:
  default   the built-in defaults (= config/default.yaml), or --config;
  flange    the same with the hole search off (hole radii 999-1000 px) and spool_evidence
            flange: every frame measured the way a frame without a hole rim is (flange centre,
            Eq. 3.2 depth, no axis). The default detector finds a hole rim on nearly every
            rendered frame, so this is how "without a hole rim" is measured.
The tools are copied to WORK/tools first and run from there, so that a build in the shared
workspace cannot swap a library during a run.

Each detection is joined with its frame's truth (frame_%05d.json). On detections whose flange
centre lies on the slot spool's (the truth's `flange`, within max(3 px, 0.1 r) of its ellipse
centre; other outcomes are counted, not measured), per frame:
  r_px        detector flange r - truth flange r (both the mean semi-axis), px
  r_eq_px     the radius error the depth implies, fy*R/distance - fy*R/true_depth, px
              (distance uses the vertical semi-axis, which spool_detect does not print)
  centre_px   the measured bore front centre (the hole rim's centre, else the flange centre:
              what `position` is built on) - the truth's projected bore front centre, px
  depth_rel   (distance - true depth) / true depth
  lateral_mm  lateral_offset - true lateral_offset, mm
  axis_yaw_deg, axis_angle_deg  detector - truth, degrees (hole rim only)
Groups: size x hole rim (found / none / flange pass) x flange whole or cut (truth flange
visible_fraction < 0.95) x true depth band (50-60, 60-80, 80-110 cm). Per group and quantity:
n, median and mean of the signed error, robust sigma 1.4826*MAD about the median (for the
centre: per image axis, dx and dy pooled) and p95 of |error| (the centre: of the 2-D distance).
Fitted per size: sigma_r_px (sigma_depth/depth = sigma_r_px * depth / (fy*R)), sigma_centre_px,
axis sigma and bias, the factor for a cut flange (same set and band) and for no hole rim (the
same frames, flange pass over default pass).

Prints a markdown report on stdout (progress on stderr) and writes every number as JSON (--out,
default WORK/error_model.json; each frame's record goes to WORK/frames.jsonl).
Exit: 0 done, 1 a tool failed, 2 bad arguments.
"""
import argparse
import concurrent.futures
import datetime
import glob
import hashlib
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import time

import numpy as np
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FLANGE_RADIUS_M = 0.175  # flange_diameter / 2 (config/default.yaml)
SETS = ("main", "hard", "distorted", "approach")
TUNING_SEEDS = set(range(11, 17))  # the detector was tuned on these: never measure on them
BANDS = ((0.50, 0.60, "50-60"), (0.60, 0.80, "60-80"), (0.80, 1.10, "80-110"))
CUT_VISIBLE = 0.95  # truth flange visible_fraction below this = flange cut by the image border
QUANTITIES = ("r_px", "r_eq_px", "centre_px", "depth_rel", "lateral_mm", "vertical_mm", "axis_yaw_deg",
              "axis_angle_deg")
FLANGE_PASS = {"spool_evidence": "flange", "hole_radius_min": 999, "hole_radius_max": 1000}
MIN_N = 6  # least frames in each of two strata for their sigma ratio to count in a factor
# Hole condition of a measured frame: a rim found (default pass), none found (default pass), or
# the flange pass (hole search off).
HOLE_CONDS = (("hole", "yes"), ("nohole", "no"), ("flange", "off"))


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def spool_ws():
    ws = os.environ.get("SPOOL_WS")
    if ws:
        return ws
    out = subprocess.run(["bash", "-c", 'source "$0/scripts/env.sh" >/dev/null && echo "$SPOOL_WS"', ROOT],
                         capture_output=True, text=True, check=True)
    return out.stdout.strip()


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", help="JSON output (default: WORK/error_model.json)")
    p.add_argument("--work", help="render/detect folder, outside the repository (default: $SPOOL_WS/error_model)")
    p.add_argument("--bin", help="folder of spool_render and spool_detect (default: $SPOOL_WS/devel/lib/spool_vision)")
    p.add_argument("--config", help="detector YAML (default: spool_detect's built-in defaults, which equal "
                   "config/default.yaml and need no file that an edit in progress may change)")
    p.add_argument("--sizes", default="160x120,320x240,640x480,1280x720", help="image sizes (default: all four)")
    p.add_argument("--seeds", default="21,22", help="render seeds (11-16 tuned the detector: refused)")
    p.add_argument("--sets", default=",".join(SETS), help="spool_render sets (default: %(default)s)")
    p.add_argument("--count", type=int, help="frames per set and seed below 720 rows (default 80, --quick 20)")
    p.add_argument("--count-hd", type=int, help="the same at 720 rows and up (default 50, --quick 12)")
    p.add_argument("--approach-count", type=int, help="approach frames per seed (default 60, --quick 20)")
    p.add_argument("--jobs", type=int, default=2, help="tools run at once (default 2)")
    p.add_argument("--quick", action="store_true", help="a smaller run (about a minute)")
    p.add_argument("--fresh", action="store_true", help="render again even where a matching render exists")
    a = p.parse_args(argv)
    a.count = a.count or (20 if a.quick else 80)
    a.count_hd = a.count_hd or (12 if a.quick else 50)
    a.approach_count = a.approach_count or (20 if a.quick else 60)
    try:
        a.sizes = [tuple(int(v) for v in s.lower().split("x")) for s in a.sizes.split(",")]
        a.seeds = [int(s) for s in a.seeds.split(",")]
    except ValueError:
        p.error("--sizes is WxH,... and --seeds S,...")
    if any(len(s) != 2 or min(s) <= 0 for s in a.sizes):
        p.error("--sizes is WxH,...")
    if TUNING_SEEDS & set(a.seeds):
        p.error("seeds 11-16 were used to tune the detector: measure on others (default 21,22)")
    a.sets = a.sets.split(",")
    if not set(a.sets) <= set(SETS):
        p.error("--sets: a list of " + ",".join(SETS))
    if min(a.count, a.count_hd, a.approach_count, a.jobs) <= 0:
        p.error("counts and --jobs must be positive")
    if a.config and not os.path.isfile(a.config):
        p.error("--config: no file " + a.config)
    if not a.work or not a.bin:
        ws = spool_ws()
        a.work = a.work or os.path.join(ws, "error_model")
        a.bin = a.bin or os.path.join(ws, "devel", "lib", "spool_vision")
    a.work = os.path.abspath(a.work)
    if (a.work + os.sep).startswith(ROOT + os.sep):
        p.error("--work must be outside the repository")
    a.out = a.out or os.path.join(a.work, "error_model.json")
    return a


# ---------------------------------------------------------------------------------------------
# Tools, rendering and detection


def snapshot_tools(args):
    """Copies spool_render, spool_detect and the package's libraries into WORK/tools, to be run
    from there (LD_LIBRARY_PATH beats their RUNPATH). Returns the newest copied file's time."""
    lib_dir = os.path.dirname(os.path.abspath(args.bin.rstrip("/")))  # devel/lib
    tools = os.path.join(args.work, "tools")
    shutil.rmtree(tools, ignore_errors=True)
    os.makedirs(os.path.join(tools, "lib"))
    for tool in ("spool_render", "spool_detect"):
        shutil.copy2(os.path.join(args.bin, tool), tools)
    libs = sorted(glob.glob(os.path.join(lib_dir, "libspool_vision_*.so*")))
    for lib in libs:
        shutil.copy2(lib, os.path.join(tools, "lib"))
    args.tools = tools
    args.env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(tools, "lib") + (
        ":" + os.environ["LD_LIBRARY_PATH"] if os.environ.get("LD_LIBRARY_PATH") else ""))
    digest = hashlib.sha1()
    for f in [os.path.join(tools, "spool_render")] + sorted(glob.glob(os.path.join(tools, "lib", "*.so*"))):
        with open(f, "rb") as fh:
            digest.update(fh.read())
    args.renderer_hash = digest.hexdigest()[:12]
    newest = max(os.path.getmtime(f) for f in [os.path.join(args.bin, t) for t in ("spool_render", "spool_detect")]
                 + libs)
    return datetime.datetime.fromtimestamp(newest).isoformat(timespec="seconds")


def write_configs(args):
    """The two detector configurations: default (the user's --config or none) and flange."""
    base = {}
    if args.config:
        with open(args.config) as f:
            base = yaml.safe_load(f) or {}
    flange = dict(base, **FLANGE_PASS)
    path = os.path.join(args.work, "flange_pass.yaml")
    with open(path, "w") as f:
        f.write("# measure_error_model.py: %s with the hole search off\n" % (args.config or "built-in defaults"))
        yaml.safe_dump(flange, f, default_flow_style=False)
    args.passes = {"default": ["--config", args.config] if args.config else [], "flange": ["--config", path]}


def run_tool(cmd, env):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        hint = ""
        if r.returncode < 0:
            hint = ("\n(killed by signal %d: if a build is under way, a library newer than the tool may not "
                    "match it; rerun after the build)" % -r.returncode)
        raise RuntimeError("%s failed (%d): %s\n%s%s" % (os.path.basename(cmd[0]), r.returncode, " ".join(cmd),
                                                         r.stderr.strip()[-2000:], hint))
    return r.stdout


def smoke_test(args):
    """Both tools run, with both configurations, on one frame (a half-finished build may not)."""
    folder = os.path.join(args.work, "smoke")
    shutil.rmtree(folder, ignore_errors=True)
    try:
        run_tool([os.path.join(args.tools, "spool_render"), "--out", folder, "--width", "160", "--height", "120",
                  "--count", "1", "--seed", str(args.seeds[0]), "--set", "main"], args.env)
        for extra in args.passes.values():
            run_tool([os.path.join(args.tools, "spool_detect")] + extra +
                     ["--camera-info", os.path.join(folder, "camera_info.yaml"), folder], args.env)
    except RuntimeError as e:
        raise RuntimeError("the tools do not run; is a build under way? Rerun after it.\n" + str(e))


def git_state():
    try:
        head = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
        return head + (" with uncommitted changes" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def frames_for(args, size, set_name):
    if set_name == "approach":
        return args.approach_count
    return args.count_hd if size[1] >= 720 else args.count


def render_folder(args, size, set_name, seed, count):
    """Renders spool_render's `set_name` (count frames, seed) at size into WORK/WxH/SET_sSEED,
    unless a render made there with the same options by the same tools exists (args.fresh:
    always render). Returns (folder, reused). Also used by evaluate_tracking.py."""
    w, h = size
    folder = os.path.join(args.work, "%dx%d" % size, "%s_s%d" % (set_name, seed))
    cmd = [os.path.join(args.tools, "spool_render"), "--out", folder, "--width", str(w), "--height", str(h),
           "--count", str(count), "--seed", str(seed), "--set", set_name]
    stamp = " ".join(cmd[1:]) + " tools=" + args.renderer_hash
    stamp_file = os.path.join(folder, "render_stamp.txt")
    reused = not args.fresh and os.path.exists(stamp_file) and open(stamp_file).read() == stamp
    if not reused:
        if os.path.isdir(folder):
            for f in os.listdir(folder):
                if f.startswith("frame_") or f in ("camera_info.yaml", "render_stamp.txt"):
                    os.remove(os.path.join(folder, f))
        run_tool(cmd, args.env)
        with open(stamp_file, "w") as f:
            f.write(stamp)
    return folder, reused


def run_job(args, size, set_name, seed):
    """Renders one folder (unless a matching render exists), detects it with both passes and
    returns the measured frames."""
    count = frames_for(args, size, set_name)
    t0 = time.time()
    folder, reused = render_folder(args, size, set_name, seed, count)
    t1 = time.time()
    truths = {}
    frames = []
    for pass_name, extra in args.passes.items():
        out = run_tool([os.path.join(args.tools, "spool_detect")] + extra +
                       ["--camera-info", os.path.join(folder, "camera_info.yaml"), folder], args.env)
        lines = out.splitlines()
        if len(lines) != count:
            raise RuntimeError("%s: %d detections for %d frames" % (folder, len(lines), count))
        for line in lines:
            det = json.loads(line)
            path = os.path.splitext(det["image"])[0] + ".json"
            if path not in truths:
                with open(path) as f:
                    truths[path] = json.load(f)
            frames.append(measure(size, set_name, seed, pass_name, truths[path], det))
    log("  %-9s %-9s seed %d: %3d frames, render %s, detect %.1f s"
        % ("%dx%d" % size, set_name, seed, count, "reused" if reused else "%.1f s" % (t1 - t0), time.time() - t1))
    return frames


# ---------------------------------------------------------------------------------------------
# Per-frame measurement


def nan_if_none(v):
    return float("nan") if v is None else float(v)


def near(truth_flange, det_flange):
    """The evaluation's centre rule: within max(3 px, 0.1 r) of the truth's ellipse centre."""
    tol = max(3.0, 0.1 * truth_flange["r"])
    return math.hypot(det_flange["x"] - truth_flange["x"], det_flange["y"] - truth_flange["y"]) <= tol


def band_of(depth):
    for lo, hi, name in BANDS:
        if lo <= depth < hi or (hi == BANDS[-1][1] and depth == hi):
            return name
    return None


def in_view(c, w, h):
    return -0.5 <= c["centre_x"] <= w - 0.5 and -0.5 <= c["centre_y"] <= h - 0.5


def measure(size, set_name, seed, pass_name, t, d):
    w, h = size
    rec = {"size": "%dx%d" % size, "set": set_name, "seed": seed, "index": t["index"], "kind": t["kind"],
           "pass": pass_name, "detected": bool(d.get("detected")), "hole": bool(d.get("hole_detected"))}
    slot = t.get("flange")
    neighbours = [(n["flange"], n["yaw"]) for n in t.get("neighbours", [])]
    if not rec["detected"]:
        rec["outcome"] = "missed" if slot is not None else "negative_ok"
        return rec
    df = d["flange"]
    if slot is None:  # an empty slot or a round object: a neighbour is a spool, anything else is not
        rec["outcome"] = "neighbour" if any(near(f, df) for f, _ in neighbours) else "false_spool"
        return rec
    depth = t["distance"]
    rec.update(depth=depth, band=band_of(depth), visible=slot["visible_fraction"],
               cut=slot["visible_fraction"] < CUT_VISIBLE)
    if not near(slot, df):
        # Beside the slot: a neighbour the evaluation would take as well (the in-view spool of
        # least |bearing|, ties within 1 deg) has no 3D truth here and is not measured; another
        # neighbour, or no spool at all, is a wrong target.
        spools = [(slot, t["yaw"])] + neighbours
        viewed = [abs(y) for f, y in spools if in_view(f, w, h)]
        on = [y for f, y in neighbours if near(f, df)]
        if on and viewed and abs(abs(on[0]) - min(viewed)) <= math.radians(1.0):
            rec["outcome"] = "neighbour"
        else:
            rec["outcome"] = "wrong_target" if on else "no_spool"
        return rec
    rec["outcome"] = "target"
    rec["hole_cond"] = "flange" if pass_name == "flange" else ("hole" if rec["hole"] else "nohole")
    fy = t["camera"]["fy"]
    rec["radius_outlier"] = abs(df["r"] - slot["r"]) > 0.1 * slot["r"]
    rec["r_px"] = df["r"] - slot["r"]
    dist = nan_if_none(d["distance"])
    r_true = fy * FLANGE_RADIUS_M / depth
    rec["r_eq_px"] = fy * FLANGE_RADIUS_M / dist - r_true
    rec["depth_rel"] = (dist - depth) / depth
    c = d["hole"] if rec["hole"] else df
    rec["centre_dx"] = c["x"] - t["hole"]["centre_x"]
    rec["centre_dy"] = c["y"] - t["hole"]["centre_y"]
    rec["centre_px"] = math.hypot(rec["centre_dx"], rec["centre_dy"])
    rec["lateral_mm"] = 1000.0 * (nan_if_none(d["lateral_offset"]) - t["lateral_offset"])
    rec["vertical_mm"] = 1000.0 * (nan_if_none((d.get("position") or {}).get("y")) - t["position"]["y"])
    rec["axis_yaw_deg"] = math.degrees(nan_if_none(d["axis_yaw"]) - t["axis_yaw"])
    rec["axis_angle_deg"] = math.degrees(nan_if_none(d["axis_angle"]) - t["axis_angle"])
    if rec["hole"]:
        rec["hole_r_px"] = d["hole"]["r"] - t["hole"]["r"]  # the bore rim's radius: a depth cue of its own
    return rec


# ---------------------------------------------------------------------------------------------
# Statistics


def finite(values):
    return np.asarray([v for v in values if v is not None and math.isfinite(v)], float)


def robust_sigma(values):
    x = finite(values)
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if len(x) else float("nan")


def stats(values):
    x = finite(values)
    if len(x) == 0:
        return {"n": 0}
    return {"n": int(len(x)), "median": float(np.median(x)), "mean": float(np.mean(x)), "sigma": robust_sigma(x),
            "median_abs": float(np.median(np.abs(x))), "p95_abs": float(np.percentile(np.abs(x), 95)),
            "max_abs": float(np.max(np.abs(x)))}


def quantity_stats(recs):
    out = {q: stats([r.get(q) for r in recs]) for q in QUANTITIES}
    # The centre: sigma per image axis (dx and dy pooled about their own medians) and the bias per
    # axis; |error| (median_abs, p95_abs, max_abs) is the 2-D distance.
    dx = finite([r["centre_dx"] for r in recs])
    dy = finite([r["centre_dy"] for r in recs])
    if len(dx):
        dev = np.concatenate([np.abs(dx - np.median(dx)), np.abs(dy - np.median(dy))])
        out["centre_px"].update(sigma=float(1.4826 * np.median(dev)), mean_dx=float(np.mean(dx)),
                                mean_dy=float(np.mean(dy)), median_dx=float(np.median(dx)),
                                median_dy=float(np.median(dy)))
    return out


def sigma_of(recs, q):
    return quantity_stats(recs)[q].get("sigma", float("nan")) if recs else float("nan")


def stratified_factor(base, other, q, keys):
    """sigma(other) / sigma(base) for quantity q, compared only within strata (equal `keys`), so
    that the set and distance mix does not enter: geometric mean of the strata's ratios,
    weighted by the smaller count, over strata where both have MIN_N frames. None if none do."""
    strata = {}
    for tag, recs in (("a", base), ("b", other)):
        for r in recs:
            strata.setdefault(tuple(r[k] for k in keys), {"a": [], "b": []})[tag].append(r)
    num = den = 0.0
    for s in strata.values():
        if len(s["a"]) < MIN_N or len(s["b"]) < MIN_N:
            continue
        sa, sb = sigma_of(s["a"], q), sigma_of(s["b"], q)
        if not (sa > 0 and sb > 0):
            continue
        wgt = min(len(s["a"]), len(s["b"]))
        num += wgt * math.log(sb / sa)
        den += wgt
    return math.exp(num / den) if den else None


def tail_fraction(recs, sig_r, sig_c):
    """Frames whose radius or either centre error lies beyond 4 sigma of its median: what a
    4-sigma gate built on these sigmas would refuse."""
    if not recs or not (sig_r > 0 and sig_c > 0):
        return None
    mr = np.median([r["r_eq_px"] for r in recs])
    mx = np.median([r["centre_dx"] for r in recs])
    my = np.median([r["centre_dy"] for r in recs])
    out = sum(abs(r["r_eq_px"] - mr) > 4 * sig_r or abs(r["centre_dx"] - mx) > 4 * sig_c or
              abs(r["centre_dy"] - my) > 4 * sig_c for r in recs)
    return out / len(recs)


def condition_summary(recs):
    s = quantity_stats(recs)
    # Gaussian-equivalent sigmas from the 95th percentile about the median (1-D: 1.96 sigma; the
    # centre's 2-D distance: 2.448 sigma per axis): what the tails call for, beside the core's MAD.
    r = finite([f["r_eq_px"] for f in recs])
    dx = finite([f["centre_dx"] for f in recs])
    dy = finite([f["centre_dy"] for f in recs])
    sigma95_r = float(np.percentile(np.abs(r - np.median(r)), 95) / 1.96) if len(r) else None
    sigma95_c = (float(np.percentile(np.hypot(dx - np.median(dx), dy - np.median(dy)), 95) / 2.448)
                 if len(dx) else None)
    return {"n": len(recs), "sigma_r_px": s["r_eq_px"].get("sigma"), "p95_r_px": s["r_eq_px"].get("p95_abs"),
            "sigma95_r_px": sigma95_r, "sigma95_centre_px": sigma95_c,
            "sigma_centre_px": s["centre_px"].get("sigma"), "p95_centre_px": s["centre_px"].get("p95_abs"),
            "depth_rel_mean": s["depth_rel"].get("mean"), "depth_rel_median": s["depth_rel"].get("median"),
            "r_eq_median_px": s["r_eq_px"].get("median"),
            "axis_yaw_sigma_deg": s["axis_yaw_deg"].get("sigma"), "axis_yaw_mean_deg": s["axis_yaw_deg"].get("mean"),
            "axis_yaw_median_deg": s["axis_yaw_deg"].get("median"),
            "axis_yaw_p95_abs_deg": s["axis_yaw_deg"].get("p95_abs"),
            "axis_angle_sigma_deg": s["axis_angle_deg"].get("sigma"),
            "axis_angle_mean_deg": s["axis_angle_deg"].get("mean"),
            "axis_angle_median_deg": s["axis_angle_deg"].get("median"),
            "axis_angle_p95_abs_deg": s["axis_angle_deg"].get("p95_abs"),
            "lateral_sigma_mm": s["lateral_mm"].get("sigma"),
            "beyond_4_sigma": tail_fraction(recs, s["r_eq_px"].get("sigma", 0), s["centre_px"].get("sigma", 0))}


def analyse(frames, args):
    sizes = ["%dx%d" % s for s in args.sizes]
    counts = {}
    for res in sizes:
        for pass_name in args.passes:
            for set_name in args.sets + ["all"]:
                fr = [f for f in frames if f["size"] == res and f["pass"] == pass_name and
                      (set_name == "all" or f["set"] == set_name)]
                c = {"frames": len(fr)}
                for key in ("target", "neighbour", "wrong_target", "no_spool", "missed", "false_spool", "negative_ok"):
                    c[key] = sum(f["outcome"] == key for f in fr)
                tgt = [f for f in fr if f["outcome"] == "target"]
                c["target_hole"] = sum(f["hole"] for f in tgt)
                c["target_cut"] = sum(f["cut"] for f in tgt)
                c["radius_outlier"] = sum(f["radius_outlier"] for f in tgt)
                c["out_of_band"] = sum(f["band"] is None for f in tgt)
                counts[(res, pass_name, set_name)] = c
    measured = [f for f in frames if f["outcome"] == "target" and f["band"] is not None]
    groups = {}
    for res in sizes:
        for cond, _ in HOLE_CONDS:
            for cut in (False, True):
                for _, _, band in BANDS:
                    recs = [f for f in measured if f["size"] == res and f["hole_cond"] == cond and f["cut"] == cut
                            and f["band"] == band]
                    if recs:
                        g = quantity_stats(recs)
                        g["n"] = len(recs)
                        groups[(res, cond, "cut" if cut else "whole", band)] = g
    model = {}
    for res in sizes:
        at = [f for f in measured if f["size"] == res]
        m = {}
        for sets_key, recs_all in (("all_sets", at), ("hard_set", [f for f in at if f["set"] == "hard"])):
            summary = {}
            for cond, _ in HOLE_CONDS:
                both = [f for f in recs_all if f["hole_cond"] == cond]
                if both:
                    summary[cond] = condition_summary(both)
                for cut in (False, True):
                    recs = [f for f in both if f["cut"] == cut]
                    if recs:
                        summary[cond + ("_cut" if cut else "_whole")] = condition_summary(recs)
            m[sets_key] = summary
        hole = [f for f in at if f["hole_cond"] == "hole"]
        # Factors. Cut: hole frames, cut against whole within the same set and band. No hole rim:
        # the same frames measured by both passes (flange pass over default pass, both on the slot
        # spool), within the same set, band and cut.
        whole = [f for f in hole if not f["cut"]]
        cut = [f for f in hole if f["cut"]]
        by_frame = {(f["set"], f["seed"], f["index"]): f for f in hole}
        paired_flange = [f for f in at if f["hole_cond"] == "flange" and (f["set"], f["seed"], f["index"]) in by_frame]
        paired_hole = [by_frame[(f["set"], f["seed"], f["index"])] for f in paired_flange]
        m["factors"] = {
            "cut_r": stratified_factor(whole, cut, "r_eq_px", ("set", "band")),
            "cut_centre": stratified_factor(whole, cut, "centre_px", ("set", "band")),
            "cut_axis_yaw": stratified_factor(whole, cut, "axis_yaw_deg", ("set", "band")),
            "nohole_r": stratified_factor(paired_hole, paired_flange, "r_eq_px", ("set", "band", "cut")),
            "nohole_centre": stratified_factor(paired_hole, paired_flange, "centre_px", ("set", "band", "cut")),
            "paired_frames": len(paired_flange)}
        # Frame-to-frame correlation of the errors along an approach (consecutive frames, both on
        # the slot spool with a hole rim): a filter that takes them for white noise trusts them too much.
        pairs = {q: [] for q in ("r_eq_px", "centre_dx", "centre_dy", "lateral_mm", "axis_yaw_deg")}
        for seed in args.seeds:
            seq = {f["index"]: f for f in hole if f["set"] == "approach" and f["seed"] == seed}
            for i, f in seq.items():
                g = seq.get(i + 1)
                if g is not None:
                    for q in pairs:
                        if math.isfinite(f[q]) and math.isfinite(g[q]):
                            pairs[q].append((f[q], g[q]))
        m["approach_lag1_corr"] = {"pairs": len(pairs["r_eq_px"])}
        for q, pr in pairs.items():
            if len(pr) >= 5:
                x = np.asarray(pr)
                m["approach_lag1_corr"][q] = float(np.corrcoef(x[:, 0], x[:, 1])[0, 1])
        # Biases over every hole-rim frame of the size (a mean error the filter cannot remove).
        if hole:
            s = quantity_stats(hole)
            m["bias_hole"] = {q: {"mean": s[q].get("mean"), "median": s[q].get("median")} for q in QUANTITIES}
            m["bias_hole"]["centre_px"] = {k: s["centre_px"][k] for k in ("mean_dx", "mean_dy", "median_dx",
                                                                          "median_dy")}
        flange = [f for f in at if f["hole_cond"] == "flange"]
        if flange:
            s = quantity_stats(flange)
            m["bias_flange_pass"] = {q: {"mean": s[q].get("mean"), "median": s[q].get("median")}
                                     for q in ("r_eq_px", "depth_rel", "lateral_mm", "vertical_mm")}
            m["bias_flange_pass"]["centre_px"] = {k: s["centre_px"][k] for k in ("mean_dx", "mean_dy")}
        m["per_set_hole"] = {}
        for set_name in args.sets:
            recs = [f for f in hole if f["set"] == set_name]
            if recs:
                m["per_set_hole"][set_name] = condition_summary(recs)
        model[res] = m
    return counts, groups, model


# ---------------------------------------------------------------------------------------------
# Report


def fmt(v, digits=2, sign=False):
    if v is None or not isinstance(v, (int, float)) or not math.isfinite(v):
        return "-"
    return ("%+.*f" if sign else "%.*f") % (digits, v)


def cell(s, scale=1.0, digits=2, signed=True):
    """'sigma / p95|e| / median' of one quantity (the centre: the median 2-D distance)."""
    if not s or s.get("n", 0) == 0:
        return "-"
    return "%s / %s / %s" % (fmt(s["sigma"] * scale, digits), fmt(s["p95_abs"] * scale, digits),
                             fmt(s["median"] * scale, digits, sign=signed))


def markdown(counts, groups, model, meta):
    L = ["### Outcomes per size (all sets; default pass, flange pass in brackets)", "",
         "| size | frames | on slot spool | with hole rim / cut | radius >10% off | on a neighbour (taken as target) "
         "| wrong target | no spool | missed | false spool (empty slot, objects) | slot spool outside 50-110 cm |",
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        c = counts[(res, "default", "all")]
        k = counts[(res, "flange", "all")]
        L.append("| %s | %d | %d (%d) | %d / %d | %d (%d) | %d (%d) | %d (%d) | %d (%d) | %d (%d) | %d (%d) | %d |"
                 % (res, c["frames"], c["target"], k["target"], c["target_hole"], c["target_cut"],
                    c["radius_outlier"], k["radius_outlier"], c["neighbour"], k["neighbour"], c["wrong_target"],
                    k["wrong_target"], c["no_spool"], k["no_spool"], c["missed"], k["missed"], c["false_spool"],
                    k["false_spool"], c["out_of_band"]))
    L += ["", "### Per group: robust sigma / p95 |error| / median (signed)", "",
          "hole: yes = rim found, no = none found (default pass), off = flange pass (hole search off). r_eq: the "
          "radius error the depth implies (px); centre: bore front centre, sigma per image axis, p95 and median of "
          "the 2-D distance (px); depth: relative (%); lateral (mm); axis yaw and axis angle (deg, hole rim only).", "",
          "| size | hole | flange | depth cm | n | r_eq px | centre px | depth % | lateral mm | axis yaw deg "
          "| axis angle deg |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        for cond, label in HOLE_CONDS:
            for cut in ("whole", "cut"):
                for _, _, band in BANDS:
                    g = groups.get((res, cond, cut, band))
                    if g:
                        L.append("| %s | %s | %s | %s | %d | %s | %s | %s | %s | %s | %s |"
                                 % (res, label, cut, band, g["n"], cell(g["r_eq_px"]),
                                    cell(g["centre_px"], signed=False), cell(g["depth_rel"], 100.0),
                                    cell(g["lateral_mm"], 1.0, 1), cell(g["axis_yaw_deg"]), cell(g["axis_angle_deg"])))
    L += ["", "### Fitted constants per size (1 sigma, robust; hole-rim frames at 50-110 cm)", "",
          "sigma_depth/depth = sigma_r * depth / (fy * 0.175 m); sigma_centre per image axis; p95-sigma: the "
          "Gaussian sigma with the measured 95th percentile about the median (|r_eq| = 1.96 sigma, the 2-D centre "
          "distance = 2.448 sigma), i.e. what the tails call for; beyond 4 sigma: frames whose radius or a centre "
          "axis lies beyond 4 sigma of the median (what a 4-sigma gate on these sigmas would refuse). all = the "
          "four sets pooled (mostly clean renders); hard = the webcam-like set alone.", "",
          "| size | sets | n | sigma_r px whole / cut | sigma_centre px whole / cut | p95-sigma r / centre px "
          "| axis yaw sigma / mean deg | axis angle sigma / mean deg | depth bias % | beyond 4 sigma |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        for sets_key, label in (("all_sets", "all"), ("hard_set", "hard")):
            c = model[res][sets_key]
            cw, cc, ha = c.get("hole_whole", {}), c.get("hole_cut", {}), c.get("hole", {})
            if not ha:
                continue
            L.append("| %s | %s | %d | %s / %s | %s / %s | %s / %s | %s / %s | %s / %s | %s | %s |"
                     % (res, label, ha["n"], fmt(cw.get("sigma_r_px")), fmt(cc.get("sigma_r_px")),
                        fmt(cw.get("sigma_centre_px")), fmt(cc.get("sigma_centre_px")), fmt(ha.get("sigma95_r_px")),
                        fmt(ha.get("sigma95_centre_px")), fmt(ha.get("axis_yaw_sigma_deg")),
                        fmt(ha.get("axis_yaw_mean_deg"), 2, True), fmt(ha.get("axis_angle_sigma_deg")),
                        fmt(ha.get("axis_angle_mean_deg"), 2, True),
                        fmt(ha["depth_rel_mean"] * 100.0 if ha.get("depth_rel_mean") is not None else None, 2, True),
                        fmt(ha["beyond_4_sigma"] * 100.0 if ha.get("beyond_4_sigma") is not None else None, 0) + "%"))
    L += ["", "### Cut flange and no hole rim", "",
          "Cut factor: hole-rim frames, sigma cut over sigma whole within the same set and band (strata with >= %d "
          "frames each). No-hole factor: the same frames measured by both passes, flange pass over default pass, "
          "within the same set, band and cut. Flange pass sigmas: all sets." % MIN_N, "",
          "| size | cut factor r / centre / axis yaw | no-hole factor r / centre | no hole, whole: n, sigma_r, "
          "sigma_centre | no hole, cut: n, sigma_r, sigma_centre | no hole: centre bias dx / dy px, depth bias % |",
          "| --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        m = model[res]
        f = m["factors"]
        fw = m["all_sets"].get("flange_whole", {})
        fc = m["all_sets"].get("flange_cut", {})
        b = m.get("bias_flange_pass")
        if not b:
            continue
        L.append("| %s | %s / %s / %s | %s / %s | %d, %s, %s | %d, %s, %s | %s / %s, %s |"
                 % (res, fmt(f["cut_r"], 1), fmt(f["cut_centre"], 1), fmt(f["cut_axis_yaw"], 1), fmt(f["nohole_r"], 1),
                    fmt(f["nohole_centre"], 1), fw.get("n", 0), fmt(fw.get("sigma_r_px")),
                    fmt(fw.get("sigma_centre_px")), fc.get("n", 0), fmt(fc.get("sigma_r_px")),
                    fmt(fc.get("sigma_centre_px")), fmt(b["centre_px"]["mean_dx"], 2, True),
                    fmt(b["centre_px"]["mean_dy"], 2, True), fmt(b["depth_rel"]["mean"] * 100.0, 2, True)))
    L += ["", "### Biases per size, hole-rim frames (mean / median of the signed error)", "",
          "| size | flange r px | r_eq px | depth % | centre dx / dy px (mean) | lateral mm | vertical mm "
          "| axis yaw deg | axis angle deg |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        b = model[res].get("bias_hole")
        if not b:
            continue

        def mm(q, scale=1.0, digits=2):
            return "%s / %s" % (fmt(None if b[q]["mean"] is None else b[q]["mean"] * scale, digits, True),
                                fmt(None if b[q]["median"] is None else b[q]["median"] * scale, digits, True))

        L.append("| %s | %s | %s | %s | %s / %s | %s | %s | %s | %s |"
                 % (res, mm("r_px"), mm("r_eq_px"), mm("depth_rel", 100.0), fmt(b["centre_px"]["mean_dx"], 2, True),
                    fmt(b["centre_px"]["mean_dy"], 2, True), mm("lateral_mm", 1.0, 1), mm("vertical_mm", 1.0, 1),
                    mm("axis_yaw_deg"), mm("axis_angle_deg")))
    L += ["", "### Frame-to-frame correlation of the errors along the approach sets (lag 1, hole rim)", "",
          "| size | pairs | r_eq | centre dx | centre dy | lateral | axis yaw |",
          "| --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        c = model[res]["approach_lag1_corr"]
        if c.get("pairs"):
            L.append("| %s | %d | %s | %s | %s | %s | %s |"
                     % (res, c["pairs"], fmt(c.get("r_eq_px")), fmt(c.get("centre_dx")), fmt(c.get("centre_dy")),
                        fmt(c.get("lateral_mm")), fmt(c.get("axis_yaw_deg"))))
    L += ["", "### Per set, hole-rim frames", "",
          "| size | set | n | sigma_r px | sigma_centre px | p95 abs r_eq px | axis yaw sigma / mean deg |",
          "| --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        for set_name, s in model[res]["per_set_hole"].items():
            L.append("| %s | %s | %d | %s | %s | %s | %s / %s |"
                     % (res, set_name, s["n"], fmt(s["sigma_r_px"]), fmt(s["sigma_centre_px"]),
                        fmt(s["p95_r_px"]), fmt(s["axis_yaw_sigma_deg"]), fmt(s["axis_yaw_mean_deg"], 2, True)))
    return "\n".join(L)


def jsonable(obj):
    if isinstance(obj, dict):
        return {(k if isinstance(k, str) else "|".join(k)): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def main(argv):
    args = parse_args(argv)
    for tool in ("spool_render", "spool_detect"):
        if not os.access(os.path.join(args.bin, tool), os.X_OK):
            log("measure_error_model: %s not found in %s (build the package first)" % (tool, args.bin))
            return 1
    start = time.time()
    os.makedirs(args.work, exist_ok=True)
    try:
        built = snapshot_tools(args)
        write_configs(args)
        smoke_test(args)
    except (RuntimeError, OSError, yaml.YAMLError) as e:
        log("measure_error_model: " + str(e))
        return 1
    jobs = [(size, s, seed) for size in args.sizes for s in args.sets for seed in args.seeds]
    # The slowest first, so that the workers finish together.
    jobs.sort(key=lambda j: -(j[0][0] * j[0][1] * frames_for(args, j[0], j[1]) * (1.6 if j[1] == "distorted" else 1)))
    log("measure_error_model: %d folders into %s, %d at once" % (len(jobs), args.work, args.jobs))
    frames = []
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            for result in pool.map(lambda j: run_job(args, *j), jobs):
                frames.extend(result)
    except (RuntimeError, OSError, ValueError) as e:
        log("measure_error_model: " + str(e))
        return 1
    elapsed = time.time() - start
    meta = {"date": datetime.date.today().isoformat(), "sizes": ["%dx%d" % s for s in args.sizes],
            "sets": args.sets, "seeds": args.seeds,
            "frames_per_set_and_seed": {"below_720_rows": args.count, "720_rows": args.count_hd,
                                        "approach": args.approach_count},
            "frames_rendered": len(frames) // len(args.passes),
            "config": args.config or "built-in defaults (= config/default.yaml)",
            "flange_pass": "the same with " + ", ".join("%s: %s" % kv for kv in FLANGE_PASS.items()),
            "quick": args.quick, "run_time_s": round(elapsed, 1), "tools_built": built, "source": git_state(),
            "host_cores": os.cpu_count(), "machine": platform.machine(),
            "cut_rule": "truth flange visible_fraction < %.2f" % CUT_VISIBLE,
            "target_rule": "detector flange centre within max(3 px, 0.1 r) of the slot spool's ellipse centre",
            "bands_m": [[lo, hi] for lo, hi, _ in BANDS]}
    counts, groups, model = analyse(frames, args)
    print("## Detector error model (%s; seeds %s; %d frames; %.0f s)\n"
          % (meta["date"], ",".join(map(str, args.seeds)), meta["frames_rendered"], elapsed))
    print(markdown(counts, groups, model, meta))
    out = {"meta": meta, "counts": counts, "groups": groups, "model": model,
           "quantities": {"r_px": "detector flange r - truth flange r (mean semi-axis), px",
                          "r_eq_px": "fy*R/distance - fy*R/true depth: the radius error the depth implies, px",
                          "centre_px": "bore front centre (hole centre, else flange centre) - truth projected front "
                                       "centre; sigma per image axis, |error| the 2-D distance, px",
                          "depth_rel": "(distance - true depth) / true depth",
                          "lateral_mm": "lateral_offset - true lateral_offset, mm",
                          "vertical_mm": "position.y - true position.y, mm",
                          "axis_yaw_deg": "axis_yaw - true axis_yaw, deg (hole rim only)",
                          "axis_angle_deg": "axis_angle - true axis_angle, deg (hole rim only)"},
           "stats": "n; median, mean: of the signed error; sigma: 1.4826*MAD about the median; p95_abs, "
                    "median_abs, max_abs: of |error|",
           "group_keys": "size|hole condition (hole, nohole: default pass; flange: flange pass)|whole or cut|band"}
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(jsonable(out), f, indent=1)
    with open(os.path.join(args.work, "frames.jsonl"), "w") as f:  # every frame, to analyse further
        for r in frames:
            f.write(json.dumps(jsonable(r)) + "\n")
    log("measure_error_model: %d frames in %.0f s; JSON: %s" % (meta["frames_rendered"], elapsed, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
