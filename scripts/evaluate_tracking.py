#!/usr/bin/python3
"""Measures the tracker (spool_detect --track) over whole approach sequences, beside the per-frame detector.

    evaluate_tracking.py [--out FILE] [--quick] [--work DIR] [--sizes WxH,...] [--seeds S,S-S,...]
                         [--count N] [--rate HZ] [--dropout I,...] [--dropout-length N] [--jobs N]
                         [--fresh] [--config FILE] [--bin DIR] [--set approach|approach_hard]

Each seed is one approach sequence: spool_render's `approach` set (one spool from 110 cm to 51 cm
deep, the lateral and heading errors gone by about 62 cm, the last frames inside 60 cm aligned;
--set approach_hard: the same path through a webcam with ribbed, labelled faces, clutter and
driving blur, half of the approaches ending just off, where the puller would touch),
--count frames (default 40, spool_render's default and the rendered approach bag's), rendered at
each size into --work (default $SPOOL_WS/tracking_eval, outside the repository; reused while the
renderer is unchanged, unless --fresh). The renderer has no clock: the frames are taken at --rate
(default 10 Hz, as scripts/frames_to_bag.py and test_approach_replay.py play them), i.e. at
0.59 m / ((count - 1) / rate) = 0.15 m/s. The seeds default to 31-40: the detector was tuned on
11-16 and the tracker's error model measured on 21-22 (both refused).

On each sequence, with the set's camera_info.yaml (and --config if given):
  per-frame  spool_detect FOLDER                       every frame judged alone
  tracked    spool_detect --track --rate R FOLDER      SpoolTracker over the sequence
  dropout    spool_detect --stdin --rate R             the same paths on standard input, with
             --dropout-length consecutive frames from each --dropout index (default 20 and 30:
             mid-approach, and just before the insertion window) replaced by a path that does
             not exist: an error line, the frame never reaches the tracker. Whether the frame
             index (the stamp, i / rate) still advances on such a line is checked, not assumed:
             at the first size and seed the same run with the dropped paths left out of the list
             is compared line by line (identical = the index does not advance, the tracker sees
             no gap).

Per frame, joined with the truth (frame_%05d.json): the outcome (on the target spool, as
measure_error_model.measure judges it: flange centre within max(3 px, 0.1 r) of the truth's; on
another spool; on no spool; not detected; a coasting frame, which has no rims, by its position
projected into the image), the relative depth error of `distance`, `aligned` against the truth's
`aligned` (puller clears at 50-60 cm) and `puller_clears` (false: the puller would touch the
bore), and for tracked frames the track state, refused detections (increments of `rejected`),
whether the 3-sigma ellipsoid of `position_covariance` holds the truth's `position` (the bore's
front centre: Mahalanobis distance <= 3, 97.1% for an honest Gaussian in 3-D) and time_ms split
by `full_search`.

Prints a markdown report on stdout (progress on stderr), writes every figure as JSON (--out,
default WORK/tracking_eval.json) and each frame's record to WORK/frames.jsonl.
Exit: 0 done, 1 a tool failed, 2 bad arguments.

Reuses scripts/measure_error_model.py (tool snapshot, rendering, the target rule).
"""
import argparse
import concurrent.futures
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import measure_error_model as mem  # noqa: E402  (the sibling script, imported as a module)

ERROR_MODEL_SEEDS = {21, 22}  # docs/error_model.md: the tracker's noise constants come from these
HELD = ("tracking", "coasting")
STATES = ("tracking", "coasting", "lost", "searching")
CHI_3SIGMA = 9.0  # Mahalanobis distance 3 in 3-D: P(chi2_3 <= 9) = 97.1%
HONEST_SHARE = 0.971
T_F = (0.036 - 0.031) / 2.0  # the puller's clearance in the bore (m)
FAILURES_SHOWN = 12  # failure lines printed per size and mode (all in the JSON)


def parse_seeds(text):
    seeds = []
    for part in text.split(","):
        if "-" in part:
            lo, hi = (int(v) for v in part.split("-"))
            seeds.extend(range(lo, hi + 1))
        else:
            seeds.append(int(part))
    return seeds


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", help="JSON output (default: WORK/tracking_eval.json)")
    p.add_argument("--work", help="render/detect folder, outside the repository (default: $SPOOL_WS/tracking_eval)")
    p.add_argument("--bin", help="folder of spool_render and spool_detect (default: $SPOOL_WS/devel/lib/spool_vision)")
    p.add_argument("--config", help="detector YAML (default: spool_detect's built-in defaults = config/default.yaml)")
    p.add_argument("--sizes", default="160x120,320x240,640x480,1280x720", help="image sizes (default: all four)")
    p.add_argument("--seeds", help="approach seeds, e.g. 31-40 or 31,35 (default 31-40, --quick 31-33)")
    p.add_argument("--count", type=int, default=40, help="frames per approach (default 40)")
    p.add_argument("--set", default="approach", choices=("approach", "approach_hard"),
                   help="spool_render set (default approach; approach_hard: webcam imaging, ribs, labels, driving "
                        "blur, half of the approaches ending just off)")
    p.add_argument("--rate", type=float, default=10.0, help="Hz the approach is taken at (default 10)")
    p.add_argument("--dropout", help="first frame of each dropout (default: count/2 and count*3/4, 20,30)")
    p.add_argument("--dropout-length", type=int, default=3, help="consecutive frames dropped (default 3)")
    p.add_argument("--jobs", type=int, default=2, help="sequences processed at once (default 2)")
    p.add_argument("--quick", action="store_true", help="3 seeds instead of 10")
    p.add_argument("--fresh", action="store_true", help="render again even where a matching render exists")
    a = p.parse_args(argv)
    try:
        a.sizes = [tuple(int(v) for v in s.lower().split("x")) for s in a.sizes.split(",")]
        a.seeds = parse_seeds(a.seeds or ("31-33" if a.quick else "31-40"))
        a.dropout = ([int(v) for v in a.dropout.split(",")] if a.dropout
                     else sorted({a.count // 2, (3 * a.count) // 4}))
    except ValueError:
        p.error("--sizes is WxH,..., --seeds S,S-S,... and --dropout I,...")
    if any(len(s) != 2 or min(s) <= 0 for s in a.sizes):
        p.error("--sizes is WxH,...")
    if mem.TUNING_SEEDS & set(a.seeds):
        p.error("seeds 11-16 tuned the detector: measure on others (default 31-40)")
    if ERROR_MODEL_SEEDS & set(a.seeds):
        p.error("seeds 21-22 measured the tracker's error model: measure on others (default 31-40)")
    if a.count < 10 or a.rate <= 0 or a.jobs <= 0 or a.dropout_length <= 0:
        p.error("--count >= 10; --rate, --jobs and --dropout-length positive")
    if any(i < 1 or i + a.dropout_length > a.count for i in a.dropout):
        p.error("--dropout: each dropout must start after frame 0 and end inside the sequence")
    if a.config and not os.path.isfile(a.config):
        p.error("--config: no file " + a.config)
    if not a.work or not a.bin:
        ws = mem.spool_ws()
        a.work = a.work or os.path.join(ws, "tracking_eval")
        a.bin = a.bin or os.path.join(ws, "devel", "lib", "spool_vision")
    a.work = os.path.abspath(a.work)
    if (a.work + os.sep).startswith(mem.ROOT + os.sep):
        p.error("--work must be outside the repository")
    a.out = a.out or os.path.join(a.work, "tracking_eval.json")
    a.passes = {"default": ["--config", a.config] if a.config else []}  # what mem.smoke_test runs
    return a


# ---------------------------------------------------------------------------------------------
# Running the sequences


def detect_lines(args, cmd, count, stdin=None, errors=()):
    """Runs spool_detect and returns its JSON lines; exactly the `errors` lines may be error lines
    (exit 1 then); anything else is a failure."""
    r = subprocess.run(cmd, input=stdin, capture_output=True, text=True, env=args.env)
    lines = [json.loads(line) for line in r.stdout.splitlines()]
    failed = {i for i, d in enumerate(lines) if "error" in d}
    if len(lines) != count or failed != set(errors) or r.returncode != (1 if errors else 0):
        raise RuntimeError("%s: exit %d, %d lines for %d frames, error lines %s (expected %s)\n%s"
                           % (" ".join(cmd), r.returncode, len(lines), count, sorted(failed), list(errors),
                              r.stderr.strip()[-2000:]))
    return lines


def dropped(args, start):
    return list(range(start, start + args.dropout_length))


def run_sequence(args, size, seed):
    """Renders one approach (unless a matching render exists) and runs every mode on it."""
    t0 = time.time()
    folder, reused = mem.render_folder(args, size, args.set, seed, args.count)
    t1 = time.time()
    cam = ["--camera-info", os.path.join(folder, "camera_info.yaml")]
    detect = [os.path.join(args.tools, "spool_detect")] + args.passes["default"] + cam
    rate = ["--rate", repr(args.rate)]
    paths = [os.path.join(folder, "frame_%05d.png" % i) for i in range(args.count)]
    truths = []
    for i in range(args.count):
        with open(os.path.join(folder, "frame_%05d.json" % i)) as f:
            truths.append(json.load(f))
    runs = {"per_frame": detect_lines(args, detect + [folder], args.count),
            "tracked": detect_lines(args, detect + ["--track"] + rate + [folder], args.count)}
    index_check = None
    for start in args.dropout:
        gone = dropped(args, start)
        fed = [os.path.join(folder, "dropped_frame_%05d.png" % i) if i in gone else p for i, p in enumerate(paths)]
        runs["dropout_%d" % start] = detect_lines(args, detect + ["--stdin"] + rate, args.count,
                                                  stdin="\n".join(fed) + "\n", errors=gone)
        if index_check is None and size == args.sizes[0] and seed == args.seeds[0]:
            # The same frames as a list without the dropped ones: stamped by position in the list.
            kept = [p for i, p in enumerate(paths) if i not in gone]
            listed = detect_lines(args, detect + ["--track"] + rate + kept, len(kept))
            fed_ok = [d for d in runs["dropout_%d" % start] if "error" not in d]
            same = all({k: v for k, v in a.items() if k != "time_ms"} == {k: v for k, v in b.items() if k != "time_ms"}
                       for a, b in zip(fed_ok, listed))
            index_check = {"size": "%dx%d" % size, "seed": seed, "dropout": gone, "identical_to_list_without": same,
                           "index_advances_on_error": not same}
    mem.log("  %-9s seed %d: %d frames, render %s, detect %.1f s"
            % ("%dx%d" % size, seed, args.count, "reused" if reused else "%.1f s" % (t1 - t0), time.time() - t1))
    return size, seed, truths, runs, index_check


# ---------------------------------------------------------------------------------------------
# Per-frame records


def finite(v):
    return v is not None and isinstance(v, (int, float)) and math.isfinite(v)


def outcome(size, seed, mode, t, d):
    """target, other_spool, no_spool or missed (the approach always has its spool in the slot)."""
    if not d.get("detected"):
        return "missed"
    f = d.get("flange")
    if f and f.get("r", 0) > 0:
        o = mem.measure(size, t.get("set", "approach"), seed, mode, t, d)["outcome"]
        return {"target": "target", "neighbour": "other_spool", "wrong_target": "other_spool"}.get(o, "no_spool")
    # A coasting frame has no rims: where its position projects into the image.
    p, cam = d.get("position") or {}, t["camera"]
    if not (finite(p.get("z")) and p["z"] > 0):
        return "no_spool"
    u = cam["cx"] + cam["fx"] * p["x"] / p["z"]
    v = cam["cy"] + cam["fy"] * p["y"] / p["z"]
    if math.hypot(u - t["hole"]["centre_x"], v - t["hole"]["centre_y"]) <= max(3.0, 0.1 * t["flange"]["r"]):
        return "target"
    for n in t.get("neighbours", []):
        if math.hypot(u - n["flange"]["x"], v - n["flange"]["y"]) <= 0.5 * n["flange"]["r"]:
            return "other_spool"
    return "no_spool"


def axis_errors(d, t):
    """The angle between the reported and the true spool axis (deg; atan2 of the cross and dot
    products: the 5-decimal unit vector would quantise an acos near 0 to 0.26 deg) and the larger
    error of its two slopes x/z, y/z (rad, what axis_sigma is the 1 sigma of). None without an axis."""
    a = d.get("axis")
    if not a or not finite(a.get("z")) or a["z"] <= 0:
        return None, None
    u = np.array([a[k] for k in "xyz"])
    v = np.array([t["axis"][k] for k in "xyz"])
    angle = math.degrees(math.atan2(np.linalg.norm(np.cross(u, v)), float(u @ v)))
    slope = float(max(abs(u[0] / u[2] - v[0] / v[2]), abs(u[1] / u[2] - v[1] / v[2])))
    return angle, slope


def records(size, seed, mode, truths, lines, gone=()):
    out = []
    prev = None
    for i, (t, d) in enumerate(zip(truths, lines)):
        rec = {"size": "%dx%d" % size, "seed": seed, "mode": mode, "index": i, "depth": t["distance"],
               "truth_aligned": bool(t["aligned"]), "puller_clears": bool(t["puller_clears"]),
               "clearance_mm": 1000.0 * t["puller_clearance"], "visible": t["flange"]["visible_fraction"],
               "truth_r": t["flange"]["r"], "true_axis_yaw_deg": math.degrees(t["axis_yaw"]),
               "true_lateral_mm": 1000.0 * t["lateral_offset"]}
        if i in gone:
            rec["outcome"] = "dropped"
            out.append(rec)
            continue
        dist = d.get("distance")
        axis_err, slope_err = axis_errors(d, t)
        rec.update(outcome=outcome(size, seed, mode, t, d), detected=bool(d.get("detected")),
                   hole=bool(d.get("hole_detected")), aligned=bool(d.get("aligned")),
                   depth_err=(dist - t["distance"]) / t["distance"] if finite(dist) else None,
                   lateral_err_mm=(1000.0 * (d["lateral_offset"] - t["lateral_offset"])
                                   if finite(d.get("lateral_offset")) else None),
                   axis_err_deg=axis_err, r=(d.get("flange") or {}).get("r"),
                   time_ms=d.get("time_ms"))
        if "track_state" in d:
            state = d["track_state"]
            continuing = prev is not None and prev["track_state"] in HELD
            refused = max(0, d["rejected"] - (prev["rejected"] if continuing else 0))
            raw = d.get("raw_distance")
            rec.update(state=state, age=d["track_age"], refused=refused, full_search=bool(d.get("full_search")),
                       raw_depth_err=(raw - t["distance"]) / t["distance"] if finite(raw) else None,
                       front_miss_mm=1000.0 * d["front_miss"] if finite(d.get("front_miss")) else None,
                       back_miss_mm=1000.0 * d["back_miss"] if finite(d.get("back_miss")) else None,
                       miss_sigma_mm=1000.0 * d["miss_sigma"] if finite(d.get("miss_sigma")) else None)
            if slope_err is not None and finite(d.get("axis_sigma")) and d["axis_sigma"] > 0:
                rec["axis_z"] = slope_err / d["axis_sigma"]  # the larger slope error in axis sigmas
            cov = d.get("position_covariance")
            pos = d.get("position") or {}
            if cov and all(finite(pos.get(k)) for k in "xyz"):
                e = np.array([pos[k] - t["position"][k] for k in "xyz"])
                s = np.asarray(cov, float).reshape(3, 3)
                try:
                    rec["mahal2"] = float(e @ np.linalg.solve(s, e))
                except np.linalg.LinAlgError:
                    rec["mahal2"] = float("inf")
            prev = d
        out.append(rec)
    return out


# ---------------------------------------------------------------------------------------------
# Summaries


def med(values):
    v = [x for x in values if finite(x)]
    return float(np.median(v)) if v else None


def mean(values):
    v = [x for x in values if finite(x)]
    return float(np.mean(v)) if v else None


def summarise(recs):
    """The figures of one size and mode."""
    seen = [r for r in recs if r["outcome"] != "dropped"]
    errs = [abs(r["depth_err"]) for r in seen if r.get("depth_err") is not None]
    target_errs = [abs(r["depth_err"]) for r in seen if r["outcome"] == "target" and r.get("depth_err") is not None]
    lat = [abs(r["lateral_err_mm"]) for r in seen if r["outcome"] == "target" and r.get("lateral_err_mm") is not None]
    true_al = [r for r in seen if r["truth_aligned"]]
    s = {"frames": len(seen), "sequences": len({r["seed"] for r in recs}),
         "depth_err_over_3pct": sum(e > 0.03 for e in errs), "depth_err_over_1pct": sum(e > 0.01 for e in errs),
         "max_depth_err_pct": 100.0 * max(errs) if errs else None,
         "median_depth_err_pct_on_target": 100.0 * med(target_errs) if target_errs else None,
         "p95_lateral_err_mm_on_target": float(np.percentile(lat, 95)) if lat else None,
         "on_target": sum(r["outcome"] == "target" for r in seen),
         "other_spool": sum(r["outcome"] == "other_spool" for r in seen),
         "no_spool": sum(r["outcome"] == "no_spool" for r in seen),
         "not_detected": sum(r["outcome"] == "missed" for r in seen),
         "truly_aligned": len(true_al), "aligned_on_truly_aligned": sum(r["aligned"] for r in true_al),
         "aligned_puller_would_touch": sum(r["aligned"] and not r["puller_clears"] for r in seen),
         "aligned_clears_outside_window": sum(r["aligned"] and r["puller_clears"] and not r["truth_aligned"]
                                              for r in seen),
         "time_ms_median": med(r.get("time_ms") for r in seen),
         "time_ms_mean": mean(r.get("time_ms") for r in seen),
         "axis_err_deg_median_truly_aligned": med(r.get("axis_err_deg") for r in true_al)}
    over1 = [r for r in seen if r.get("depth_err") is not None and abs(r["depth_err"]) > 0.01]
    s["depth_err_over_1pct_where"] = ({"true_depth_cm": [100.0 * min(r["depth"] for r in over1),
                                                         100.0 * max(r["depth"] for r in over1)],
                                       "long": sum(r["depth_err"] > 0 for r in over1),
                                       "flange_cut": sum(r["visible"] < mem.CUT_VISIBLE for r in over1),
                                       "sequences": len({r["seed"] for r in over1})} if over1 else None)
    s["aligned_on_truly_aligned_pct"] = (100.0 * s["aligned_on_truly_aligned"] / len(true_al)) if true_al else None
    if any("state" in r for r in seen):
        s["states"] = {st: sum(r.get("state") == st for r in seen) for st in STATES}
        s["refused"] = sum(r.get("refused", 0) for r in seen)
        s["refused_raw_within_3pct"] = sum(r.get("refused", 0) for r in seen if r.get("raw_depth_err") is not None
                                           and abs(r["raw_depth_err"]) <= 0.03)
        m2 = [r["mahal2"] for r in seen if "mahal2" in r]
        m2_fused = [r["mahal2"] for r in seen if "mahal2" in r and r.get("state") == "tracking"]
        s["covariance"] = {"frames": len(m2), "holds_3sigma": sum(v <= CHI_3SIGMA for v in m2),
                           "share_3sigma": (sum(v <= CHI_3SIGMA for v in m2) / len(m2)) if m2 else None,
                           "share_3sigma_tracking_only": (sum(v <= CHI_3SIGMA for v in m2_fused) / len(m2_fused))
                           if m2_fused else None,
                           "median_mahalanobis": math.sqrt(med(m2)) if m2 else None}
        az = [r["axis_z"] for r in seen if "axis_z" in r]
        s["axis_covariance"] = {"frames": len(az), "within_3sigma": sum(v <= 3.0 for v in az),
                                "share_3sigma": (sum(v <= 3.0 for v in az) / len(az)) if az else None}
        full = [r for r in seen if r.get("full_search")]
        win = [r for r in seen if "full_search" in r and not r["full_search"]]
        s["time_ms_full_search"] = {"frames": len(full), "median": med(r["time_ms"] for r in full),
                                    "mean": mean(r["time_ms"] for r in full)}
        s["time_ms_windowed"] = {"frames": len(win), "median": med(r["time_ms"] for r in win),
                                 "mean": mean(r["time_ms"] for r in win)}
        s["miss_mm_median_truly_aligned"] = {k: med(r.get(k + "_mm") for r in true_al)
                                             for k in ("front_miss", "back_miss", "miss_sigma")}
    return s


def dropout_summary(args, recs, start):
    """Per sequence: the track held the frame before the dropout and is neither lost nor
    searching from the dropout to the end."""
    gone = dropped(args, start)
    seqs = {}
    for r in recs:
        seqs.setdefault(r["seed"], []).append(r)
    kept = held_before = 0
    after_states = {st: 0 for st in STATES}
    refused_after = coasting_after = 0
    broken = []
    for seed, rs in sorted(seqs.items()):
        before = rs[gone[0] - 1]
        after = rs[gone[-1] + 1:]
        if before.get("state") not in HELD:
            continue
        held_before += 1
        for r in after:
            after_states[r["state"]] += 1
        refused_after += sum(r.get("refused", 0) for r in after[:5])
        coasting_after += sum(r["state"] == "coasting" for r in after[:5])
        if all(r["state"] in HELD for r in after):
            kept += 1
        else:
            first = next(r for r in after if r["state"] not in HELD)
            broken.append({"seed": seed, "frame": first["index"], "state": first["state"]})
    return {"dropped": gone, "sequences_held_before": held_before, "track_kept": kept,
            "states_after": after_states, "refused_first_5_after": refused_after,
            "coasting_first_5_after": coasting_after, "broken": broken}


def per_sequence(frames, sizes, seeds, modes):
    """Per size and seed: the approach's initial heading and lateral offset, and per mode the
    frames aligned among the truly aligned ones, with the tracked misses on the first of them."""
    out = {}
    for res in sizes:
        out[res] = {}
        for seed in seeds:
            row = {}
            for mode in modes:
                rs = [r for r in frames[(res, mode)] if r["seed"] == seed]
                if not rs:
                    continue
                row.setdefault("initial_heading_deg", rs[0]["true_axis_yaw_deg"])
                row.setdefault("initial_lateral_mm", rs[0]["true_lateral_mm"])
                true_al = [r for r in rs if r["truth_aligned"] and r["outcome"] != "dropped"]
                m = {"aligned_on_truly_aligned": sum(r["aligned"] for r in true_al), "truly_aligned": len(true_al),
                     "pattern": "".join("A" if r["aligned"] else "." for r in true_al)}
                first = next((r for r in rs if r["truth_aligned"]), None)
                if first is not None and "back_miss_mm" in first:
                    m.update({k: first.get(k) for k in ("front_miss_mm", "back_miss_mm", "miss_sigma_mm",
                                                        "axis_err_deg")})
                row[mode] = m
            out[res][str(seed)] = row
    return out


def failures(recs):
    """Frames worth reading: off target, depth over 3%, an unsafe aligned, a lost or refused frame."""
    out = []
    for r in recs:
        if r["outcome"] == "dropped":
            continue
        why = []
        if r["outcome"] != "target":
            why.append(r["outcome"])
        if r.get("depth_err") is not None and abs(r["depth_err"]) > 0.03:
            why.append("depth %+.1f%%" % (100.0 * r["depth_err"]))
        if r.get("aligned") and not r["puller_clears"]:
            why.append("UNSAFE aligned")
        if r.get("state") == "lost":
            why.append("lost")
        if r.get("refused"):
            why.append("refused %d (raw %s)" % (r["refused"], "-" if r.get("raw_depth_err") is None
                                                  else "%+.1f%%" % (100.0 * r["raw_depth_err"])))
        if why:
            out.append(dict(r, why=", ".join(why)))
    return out


# ---------------------------------------------------------------------------------------------
# Report


def fmt(v, digits=1, sign=False):
    return mem.fmt(v, digits, sign)


def markdown(args, summary, drop, fails, seqs, index_check, meta):
    L = ["Sequences: spool_render `%s`, %d frames at %g Hz (%.2f m/s), seeds %s; per-frame = `spool_detect`, "
         "tracked = `spool_detect --track --rate %g`. Depth error: |distance - true depth| / true depth on every "
         "frame that reports a distance. Aligned needs 1/fy <= aligned_max_pixel_angle per frame (default: "
         "640x480 and up) and <= track_aligned_max_pixel_angle tracked (default: the same)." % (args.set, args.count, args.rate, 0.59 * args.rate / (args.count - 1),
                                            ",".join(map(str, args.seeds)), args.rate), "",
         "### Accuracy and aligned", "",
         "| size | mode | frames | depth err >3% / >1% | max depth err % | median on target % | other spool / no spool "
         "/ not detected | aligned on truly aligned | aligned, puller would touch | aligned, clears outside 50-60 cm "
         "| axis err on truly aligned deg |",
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        for mode in ("per_frame", "tracked"):
            s = summary[res][mode]
            L.append("| %s | %s | %d | %d / %d | %s | %s | %d / %d / %d | %d/%d (%s%%) | %d | %d | %s |"
                     % (res, mode.replace("_", "-"), s["frames"], s["depth_err_over_3pct"], s["depth_err_over_1pct"],
                        fmt(s["max_depth_err_pct"], 2), fmt(s["median_depth_err_pct_on_target"], 2), s["other_spool"],
                        s["no_spool"], s["not_detected"], s["aligned_on_truly_aligned"], s["truly_aligned"],
                        fmt(s["aligned_on_truly_aligned_pct"], 0), s["aligned_puller_would_touch"],
                        s["aligned_clears_outside_window"], fmt(s["axis_err_deg_median_truly_aligned"], 2)))
    L += ["", "### Tracker", "",
          "Refused: detections the gate refused (in brackets: of them with a raw depth within 3%% of the truth). "
          "3-sigma: share of frames with a position_covariance whose Mahalanobis distance to the truth's bore front "
          "centre is <= 3 (honest: %.1f%%; in brackets: fused frames only). Misses on the truly aligned frames: "
          "median tracked front / back miss and its sigma (mm), against t_f - aligned_margin = 2.4 mm with 3 sigma. "
          "Time: time_ms, median / mean (frames)." % (100 * HONEST_SHARE), "",
          "| size | tracking / coasting / lost / searching | refused | 3-sigma holds truth | median Mahalanobis "
          "| axis within 3 axis_sigma | front / back miss / sigma mm | per-frame ms median | tracked full-search ms "
          "| tracked windowed ms |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        t, p = summary[res]["tracked"], summary[res]["per_frame"]
        st, cv, mi, ac = t["states"], t["covariance"], t["miss_mm_median_truly_aligned"], t["axis_covariance"]
        L.append("| %s | %d / %d / %d / %d | %d (%d) | %d/%d = %s%% (%s%%) | %s | %s%% | %s / %s / %s | %s "
                 "| %s / %s (%d) | %s / %s (%d) |"
                 % (res, st["tracking"], st["coasting"], st["lost"], st["searching"], t["refused"],
                    t["refused_raw_within_3pct"], cv["holds_3sigma"], cv["frames"],
                    fmt(None if cv["share_3sigma"] is None else 100 * cv["share_3sigma"]),
                    fmt(None if cv["share_3sigma_tracking_only"] is None else 100 * cv["share_3sigma_tracking_only"]),
                    fmt(cv["median_mahalanobis"], 2),
                    fmt(None if ac["share_3sigma"] is None else 100 * ac["share_3sigma"]), fmt(mi["front_miss"], 2), fmt(mi["back_miss"], 2),
                    fmt(mi["miss_sigma"], 2), fmt(p["time_ms_median"], 2), fmt(t["time_ms_full_search"]["median"], 2),
                    fmt(t["time_ms_full_search"]["mean"], 2), t["time_ms_full_search"]["frames"],
                    fmt(t["time_ms_windowed"]["median"], 2), fmt(t["time_ms_windowed"]["mean"], 2),
                    t["time_ms_windowed"]["frames"]))
    L += ["", "### Aligned per sequence", "",
          "Frames with `aligned` among the truly aligned ones: per-frame / tracked / each dropout run; the "
          "approach's initial heading (the spool axis's yaw seen from the camera, turned to 0 by 62 cm) and lateral "
          "offset.", "",
          "| seed | heading deg | lateral cm | " + " | ".join(meta["sizes"]) + " |",
          "| --- | --- | --- | " + " | ".join("---" for _ in meta["sizes"]) + " |"]
    for seed in args.seeds:
        rows = [seqs[res].get(str(seed), {}) for res in meta["sizes"]]
        any_row = next((r for r in rows if r), None)
        if not any_row:
            continue
        cells = []
        for r in rows:
            cells.append("/".join("%d" % r[m]["aligned_on_truly_aligned"] if m in r else "-" for m in
                                  ["per_frame", "tracked"] + ["dropout_%d" % d for d in args.dropout]) +
                         " of %d" % r["per_frame"]["truly_aligned"])
        L.append("| %d | %+.2f | %+.1f | %s |" % (seed, any_row["initial_heading_deg"],
                                                  any_row["initial_lateral_mm"] / 10.0, " | ".join(cells)))
    L += ["", "### Dropout: %d consecutive frames fed as unreadable paths (`--stdin`)" % args.dropout_length, ""]
    if index_check:
        L.append("Frame index on an unreadable path: %s (checked at %s, seed %d: the stdin run %s the run given the "
                 "list without the dropped frames)." % (
                     "advances (the stamp is i / rate by position in the input: the tracker predicts across the gap)"
                     if index_check["index_advances_on_error"] else
                     "does NOT advance (the next frame takes the dropped one's stamp: the tracker sees no gap)",
                     index_check["size"], index_check["seed"],
                     "differs from" if index_check["index_advances_on_error"] else "is identical to"))
        L.append("")
    L += ["| size | dropped frames | track kept (held before) | after: tracking / coasting / lost / searching "
          "| refused, coasting in the 5 frames after | depth err >3% | aligned on truly aligned | aligned, would touch |"
          " broken tracks (seed: frame state) |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        for key, d in drop[res].items():
            s = summary[res][key]
            a = d["states_after"]
            L.append("| %s | %d-%d | %d/%d | %d / %d / %d / %d | %d, %d | %d | %d/%d | %d | %s |"
                     % (res, d["dropped"][0], d["dropped"][-1], d["track_kept"], d["sequences_held_before"],
                        a["tracking"], a["coasting"], a["lost"], a["searching"], d["refused_first_5_after"],
                        d["coasting_first_5_after"], s["depth_err_over_3pct"], s["aligned_on_truly_aligned"],
                        s["truly_aligned"], s["aligned_puller_would_touch"],
                        ", ".join("%d: %d %s" % (b["seed"], b["frame"], b["state"]) for b in d["broken"]) or "-"))
    L += ["", "### Frames off target, over 3%% depth, unsafe, lost or refused (first %d per size and mode)"
          % FAILURES_SHOWN, "",
          "| size | mode | seed | frame | true depth cm | flange in view | r px (truth) | hole rim | state | why |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for res in meta["sizes"]:
        for mode in ("per_frame", "tracked"):
            fl = fails[res][mode]
            for r in fl[:FAILURES_SHOWN]:
                L.append("| %s | %s | %d | %d | %.1f | %.0f%% | %s (%.1f) | %s | %s | %s |"
                         % (res, mode.replace("_", "-"), r["seed"], r["index"], 100 * r["depth"], 100 * r["visible"],
                            fmt(r.get("r"), 1), r["truth_r"], "yes" if r.get("hole") else "no", r.get("state", "-"),
                            r["why"]))
            if len(fl) > FAILURES_SHOWN:
                L.append("| %s | %s | | | | | | | | %d more in the JSON |" % (res, mode.replace("_", "-"),
                                                                             len(fl) - FAILURES_SHOWN))
    if not any(fails[res][mode] for res in meta["sizes"] for mode in ("per_frame", "tracked")):
        L.append("| all | both | | | | | | | | none |")
    L += ["", "Depth errors over 1%:"]
    for res in meta["sizes"]:
        for mode in ("per_frame", "tracked"):
            w = summary[res][mode]["depth_err_over_1pct_where"]
            if w:
                L.append("- %s %s: %d frames in %d sequences, true depth %.0f-%.0f cm, %d long (distance too far), "
                         "%d with the flange cut by the border" % (
                             res, mode.replace("_", "-"), summary[res][mode]["depth_err_over_1pct"], w["sequences"],
                             w["true_depth_cm"][0], w["true_depth_cm"][1], w["long"], w["flange_cut"]))
    return "\n".join(L)


def main(argv):
    args = parse_args(argv)
    for tool in ("spool_render", "spool_detect"):
        if not os.access(os.path.join(args.bin, tool), os.X_OK):
            mem.log("evaluate_tracking: %s not found in %s (build the package first)" % (tool, args.bin))
            return 1
    start = time.time()
    os.makedirs(args.work, exist_ok=True)
    try:
        built = mem.snapshot_tools(args)
        mem.smoke_test(args)
    except (RuntimeError, OSError) as e:
        mem.log("evaluate_tracking: " + str(e))
        return 1
    jobs = sorted(((size, seed) for size in args.sizes for seed in args.seeds), key=lambda j: -j[0][0] * j[0][1])
    mem.log("evaluate_tracking: %d sequences into %s, %d at once" % (len(jobs), args.work, args.jobs))
    results = []
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            results = list(pool.map(lambda j: run_sequence(args, *j), jobs))
    except (RuntimeError, OSError, ValueError) as e:
        mem.log("evaluate_tracking: " + str(e))
        return 1
    elapsed = time.time() - start
    modes = ["per_frame", "tracked"] + ["dropout_%d" % s for s in args.dropout]
    frames = {("%dx%d" % s, m): [] for s in args.sizes for m in modes}
    index_check = None
    for size, seed, truths, runs, check in sorted(results, key=lambda r: (r[0][1], r[1])):
        index_check = index_check or check
        for mode, lines in runs.items():
            gone = dropped(args, int(mode.split("_")[1])) if mode.startswith("dropout") else ()
            frames[("%dx%d" % size, mode)].extend(records(size, seed, mode, truths, lines, gone))
    sizes = ["%dx%d" % s for s in args.sizes]
    summary = {res: {m: summarise(frames[(res, m)]) for m in modes} for res in sizes}
    drop = {res: {"dropout_%d" % s: dropout_summary(args, frames[(res, "dropout_%d" % s)], s) for s in args.dropout}
            for res in sizes}
    fails = {res: {m: failures(frames[(res, m)]) for m in ("per_frame", "tracked")} for res in sizes}
    meta = {"date": datetime.date.today().isoformat(), "set": args.set, "sizes": sizes, "seeds": args.seeds,
            "count": args.count,
            "rate_hz": args.rate, "speed_m_s": 0.59 * args.rate / (args.count - 1), "dropout_starts": args.dropout,
            "dropout_length": args.dropout_length, "config": args.config or "built-in defaults (= config/default.yaml)",
            "quick": args.quick, "run_time_s": round(elapsed, 1), "tools_built": built, "source": mem.git_state(),
            "host_cores": os.cpu_count(), "machine": platform.machine(), "index_check": index_check,
            "covariance_rule": "Mahalanobis distance of the truth's position (bore front centre) from the published "
                               "position under position_covariance <= 3 (chi2_3 <= 9: 97.1%)",
            "unsafe_rule": "aligned true where the truth's puller_clears is false",
            "target_rule": "measure_error_model.measure (flange centre within max(3 px, 0.1 r) of the truth's); a "
                           "coasting frame by its position projected through the truth's camera"}
    print("## Tracker over approach sequences (%s; set %s; seeds %s; %d sequences; %.0f s)\n"
          % (meta["date"], args.set, ",".join(map(str, args.seeds)), len(jobs), elapsed))
    seqs = per_sequence(frames, sizes, args.seeds, modes)
    print(markdown(args, summary, drop, fails, seqs, index_check, meta))
    out = {"meta": meta, "summary": summary, "dropout": drop, "sequences": seqs, "failures": fails}
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(mem.jsonable(out), f, indent=1)
    with open(os.path.join(args.work, "frames.jsonl"), "w") as f:
        for key in sorted(frames):
            for r in frames[key]:
                f.write(json.dumps(mem.jsonable(r)) + "\n")
    mem.log("evaluate_tracking: %d sequences in %.0f s; JSON: %s" % (len(jobs), elapsed, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
