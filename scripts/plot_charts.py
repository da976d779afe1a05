#!/usr/bin/python3
"""Draws the evaluation report's charts with matplotlib (no display needed).

    plot_charts.py CHARTS_JSON [OUT_DIR]

CHARTS_JSON is the charts.json that spool_eval writes beside report.md: {"charts": [...]}, each
chart a line chart (series of x/y points, null y = a gap, and dashed reference levels) or a
grouped bar chart (a bar per category and group, null = no bar, marked "n/a"). Each chart is
saved as the 900x540 PNG its "file" names, in OUT_DIR (default: the folder of CHARTS_JSON;
created if missing). Every chart is checked before any PNG is written.
Exit: 0 drawn; 1 matplotlib missing or a PNG not written; 2 bad arguments or a bad charts file
(the message names the chart and the key).
"""
import json
import math
import os
import sys

WIDTH_IN, HEIGHT_IN, DPI = 9.0, 5.4, 100  # 900x540 px, as the report has always shown them


class ChartError(Exception):
    """A charts file that does not hold what this script draws."""


def fail(code, message):
    print("plot_charts: " + message, file=sys.stderr)
    sys.exit(code)


def field(chart, key, kind):
    """chart[key], checked to be of `kind` (a type or a tuple of types)."""
    if key not in chart:
        raise ChartError("missing '%s'" % key)
    value = chart[key]
    if not isinstance(value, kind):
        raise ChartError("'%s' is not %s" % (key, getattr(kind, "__name__", "a number")))
    return value


def numbers(values, key):
    """A JSON list of numbers and nulls as floats, null as NaN (a gap or a missing bar)."""
    out = []
    for v in values:
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
            raise ChartError("'%s' holds %r, not a number or null" % (key, v))
        out.append(math.nan if v is None else float(v))
    return out


def draw_levels(ax, levels):
    for level in levels:
        ax.axhline(field(level, "y", (int, float)), color="0.3", linestyle="--", linewidth=1.0,
                   label=field(level, "label", str))


def draw_line(ax, chart):
    for s in field(chart, "series", list):
        x = numbers(field(s, "x", list), "x")
        y = numbers(field(s, "y", list), "y")
        if len(x) != len(y):
            raise ChartError("series '%s' has %d x and %d y values" % (s.get("label"), len(x), len(y)))
        style = "-o" if field(s, "line", bool) else "o"
        ax.plot(x, y, style, markersize=3 if style == "-o" else 5, linewidth=1.2, label=field(s, "label", str))
    draw_levels(ax, field(chart, "levels", list))
    ax.set_xlabel(field(chart, "x_label", str))


def draw_bar(ax, chart):
    categories = field(chart, "categories", list)
    groups = field(chart, "groups", list)
    width = 0.8 / max(1, len(groups))
    for k, group in enumerate(groups):
        values = numbers(field(group, "values", list), "values")
        if len(values) != len(categories):
            raise ChartError("group '%s' has %d values for %d categories"
                             % (group.get("label"), len(values), len(categories)))
        xs = [i - 0.4 + (k + 0.5) * width for i in range(len(categories))]
        bars = ax.bar(xs, values, width, label=field(group, "label", str))
        # No value is not 0%: say so where the bar would stand.
        for x, v in zip(xs, values):
            if math.isnan(v):
                ax.text(x, 0.0, "n/a", rotation=90, ha="center", va="bottom", fontsize="x-small",
                        color=bars.patches[0].get_facecolor())
    ax.set_xticks(range(len(categories)))
    ax.set_xticklabels(categories, rotation=15, ha="right")
    ax.set_xlim(-0.5, len(categories) - 0.5)  # every category, even one without a bar
    y_max = chart.get("y_max")
    if y_max is not None:
        top = numbers([y_max], "y_max")[0]
        ax.set_ylim(0.0, 1.04 * top)  # a full bar stays clear of the frame


def draw(pyplot, chart):
    """`chart` drawn as a figure (not saved yet), with the PNG name it is to be saved under."""
    name = field(chart, "file", str)
    if os.path.basename(name) != name or not name.endswith(".png"):
        raise ChartError("'file' must be a plain PNG name, not %r" % name)
    kinds = {"line": draw_line, "bar": draw_bar}
    kind = field(chart, "kind", str)
    if kind not in kinds:
        raise ChartError("'kind' is %r, not one of %s" % (kind, ", ".join(sorted(kinds))))
    figure, ax = pyplot.subplots(figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI)
    try:
        kinds[kind](ax, chart)
        ax.set_title(field(chart, "title", str))
        ax.set_ylabel(field(chart, "y_label", str))
        ax.grid(True, color="0.9")
        ax.set_axisbelow(True)
        if ax.get_legend_handles_labels()[0]:
            # Beside the plot, not on it: bars and points reach every corner.
            ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        figure.tight_layout()  # the figure keeps its size and dpi; the axes make room
        return figure, name
    except BaseException:
        pyplot.close(figure)
        raise


def main(argv):
    if len(argv) == 2 and argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0
    if len(argv) not in (2, 3) or argv[1].startswith("-"):
        fail(2, "usage: plot_charts.py CHARTS_JSON [OUT_DIR]")
    source = argv[1]
    out_dir = argv[2] if len(argv) == 3 else os.path.dirname(os.path.abspath(source))
    try:
        with open(source, encoding="utf-8") as f:
            charts = json.load(f)
    except OSError as e:
        fail(2, "cannot read %s: %s" % (source, e))
    except ValueError as e:
        fail(2, "%s is not valid JSON: %s" % (source, e))
    if not isinstance(charts, dict) or not isinstance(charts.get("charts"), list):
        fail(2, "%s: expected {\"charts\": [...]}" % source)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as pyplot
    except ImportError as e:
        fail(1, "matplotlib is missing (%s): install python3-matplotlib (scripts/install_deps.sh)" % e)
    drawn = []
    for index, chart in enumerate(charts["charts"]):
        label = "chart %d" % (index + 1)
        try:
            if not isinstance(chart, dict):
                raise ChartError("is not an object")
            label += " (%s)" % chart.get("file", "no file")
            drawn.append(draw(pyplot, chart))
        except ChartError as e:
            fail(2, "%s: %s: %s" % (source, label, e))
    try:
        os.makedirs(out_dir, exist_ok=True)
        for figure, name in drawn:
            figure.savefig(os.path.join(out_dir, name))  # no tight box: 900x540 as drawn
            pyplot.close(figure)
    except OSError as e:
        fail(1, "cannot write the charts in %s: %s" % (out_dir, e))
    print("plot_charts: %d charts in %s" % (len(drawn), out_dir))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
