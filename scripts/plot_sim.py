#!/usr/bin/python3
"""Draws spool_sim's trajectories seen from above with matplotlib (no display needed).

    plot_sim.py TRIALS_JSONL [OUT_PNG]

TRIALS_JSONL is the trials.jsonl that `spool_sim --pictures DIR` writes: one trial per line with
its outcome and "trajectory" (x and depth of the camera per control period, m). OUT_PNG (default:
trajectories.png beside TRIALS_JSONL) shows every trial's path, coloured by outcome, with the
spool's front face, the bore axis and the insertion window, and beside it the last 20 cm (from
70 cm to 50 cm) magnified sideways (mm), where the puller has to be within the bore's clearance.
Exit: 0 drawn; 1 matplotlib missing or the PNG not written; 2 bad arguments or a bad trials file.
"""
import json
import os
import sys

COLOURS = {"inserted": "tab:green", "collision": "tab:red", "wrong_spool": "tab:purple",
           "timeout": "tab:orange", "lost": "tab:gray"}


def fail(code, message):
    print("plot_sim: " + message, file=sys.stderr)
    sys.exit(code)


def read_trials(path):
    trials = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            try:
                trial = json.loads(line)
                path_points = [(float(s["x"]), float(s["depth"])) for s in trial["trajectory"]]
                outcome = str(trial["outcome"])
            except (ValueError, KeyError, TypeError) as e:
                fail(2, "%s line %d: not a spool_sim trial with a trajectory (%s)" % (path, number, e))
            if outcome not in COLOURS:
                fail(2, "%s line %d: unknown outcome '%s'" % (path, number, outcome))
            trials.append((trial.get("seed"), outcome, path_points))
    if not trials:
        fail(2, "%s: no trials" % path)
    return trials


def main(argv):
    if len(argv) not in (2, 3):
        fail(2, "usage: plot_sim.py TRIALS_JSONL [OUT_PNG]")
    source = argv[1]
    if not os.path.isfile(source):
        fail(2, "%s: no such file" % source)
    out = argv[2] if len(argv) == 3 else os.path.join(os.path.dirname(source) or ".", "trajectories.png")
    trials = read_trials(source)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        fail(1, "matplotlib is missing (Debian: python3-matplotlib)")
    figure, (whole, near) = plt.subplots(1, 2, figsize=(12, 6), dpi=100)
    counts = {}
    for seed, outcome, points in trials:
        counts[outcome] = counts.get(outcome, 0) + 1
        xs = [x for x, _ in points]
        depths = [d for _, d in points]
        whole.plot(xs, depths, color=COLOURS[outcome], linewidth=0.8, alpha=0.7)
        near.plot([1000.0 * x for x in xs], depths, color=COLOURS[outcome], linewidth=0.8, alpha=0.7)
        if outcome != "inserted":
            whole.annotate(str(seed), (xs[-1], depths[-1]), fontsize=6, color=COLOURS[outcome])
    for axes in (whole, near):
        axes.axhspan(0.5, 0.6, color="tab:blue", alpha=0.08, label="insertion window (50-60 cm)")
        axes.set_ylabel("camera to the spool's front face along its axis (m)")
    whole.axhline(0.0, color="black", linewidth=2)
    whole.axvline(0.0, color="tab:blue", linestyle="--", linewidth=0.8)
    whole.set_xlabel("camera beside the bore axis (m)")
    whole.set_title("%d trials seen from above" % len(trials))
    whole.set_ylim(-0.05, 1.3)
    near.axvspan(-2.5, 2.5, color="tab:green", alpha=0.08, label="bore clearance t_f (2.5 mm)")
    near.set_xlim(-15, 15)
    near.set_ylim(0.5, 0.7)
    near.set_xlabel("camera beside the bore axis (mm)")
    near.set_title("70 to 50 cm, sideways in mm")
    handles = [plt.Line2D([], [], color=COLOURS[o], label="%s (%d)" % (o, counts[o])) for o in COLOURS if o in counts]
    whole.legend(handles=handles, loc="upper right", fontsize=8)
    near.legend(loc="upper right", fontsize=8)
    figure.tight_layout()
    try:
        figure.savefig(out)
    except OSError as e:
        fail(1, "%s: not written (%s)" % (out, e))
    print("plot_sim: wrote " + out, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
