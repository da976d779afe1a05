#!/usr/bin/python3
"""Draws the evaluation report's charts with matplotlib (no display needed).

    plot_charts.py CHARTS_JSON [OUT_DIR]

CHARTS_JSON is the charts.json that spool_eval writes beside report.md: {"charts": [...]}, each
chart a line chart (series of x/y points, null y = a gap, and dashed reference levels) or a
grouped bar chart (a bar per category and group, null = no bar). Each chart is saved as the
900x540 PNG its "file" names, in OUT_DIR (default: the folder of CHARTS_JSON).
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
        ax.bar([i - 0.4 + (k + 0.5) * width for i in range(len(categories))], values, width,
               label=field(group, "label", str))
    ax.set_xticks(range(len(categories)))
    ax.set_xticklabels(categories, rotation=15, ha="right")
    y_max = chart.get("y_max")
    if y_max is not None:
        ax.set_ylim(0.0, numbers([y_max], "y_max")[0])


def draw(pyplot, chart, out_dir):
    """Saves `chart` as the PNG it names in `out_dir`; returns the path."""
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
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small")
        path = os.path.join(out_dir, name)
        figure.savefig(path)  # the figure size and dpi give the pixels; no tight box
        return path
    finally:
        pyplot.close(figure)


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
    except (OSError, ValueError) as e:
        fail(2, "cannot read %s: %s" % (source, e))
    if not isinstance(charts, dict) or not isinstance(charts.get("charts"), list):
        fail(2, "%s: expected {\"charts\": [...]}" % source)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as pyplot
    except ImportError as e:
        fail(1, "matplotlib is missing (%s): install python3-matplotlib (scripts/install_deps.sh)" % e)
    for index, chart in enumerate(charts["charts"]):
        label = "chart %d" % (index + 1)
        try:
            if not isinstance(chart, dict):
                raise ChartError("is not an object")
            label += " (%s)" % chart.get("file", "no file")
            draw(pyplot, chart, out_dir)
        except ChartError as e:
            fail(2, "%s: %s: %s" % (source, label, e))
        except OSError as e:
            fail(1, "%s: cannot write: %s" % (label, e))
    print("plot_charts: %d charts in %s" % (len(charts["charts"]), out_dir))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
