"""Pictures of a SpoolPose stream: a contact sheet of the detector's overlays and a plot of the
measurements against time (echo_poses.py --pictures draws both for scripts/demo.sh).

Pure functions of spool_vision/SpoolPose messages (or any object with their fields) and
sensor_msgs/Image overlays: no ROS master, no rospy. Needs numpy and cv2 (python3-opencv) for the
sheet, matplotlib (python3-matplotlib, Agg backend) for the plot, PIL (python3-pil, which
matplotlib depends on) only for a sheet saved with a reduced palette.
"""
import math
import os

import cv2
import numpy as np

# The sheet's colours (BGR). Aligned tiles get a green border: the one thing to see at a glance.
ALIGNED_BGR = (0, 200, 0)
BORDER_BGR = (90, 90, 90)
BACKGROUND_BGR = (40, 40, 40)
TEXT_BGR = (235, 235, 235)
MISSING_BGR = (25, 25, 25)
FONT = cv2.FONT_HERSHEY_SIMPLEX

# The plot: 900 px wide like the report's charts (plot_charts.py), taller for four stacked rows.
PLOT_WIDTH_IN, PLOT_HEIGHT_IN, PLOT_DPI = 9.0, 7.5, 100


def stamp_key(header):
    """The key that pairs an overlay with its pose: the node copies the camera image's header."""
    return (header.stamp.secs, header.stamp.nsecs)


def stamp_seconds(header):
    return header.stamp.secs + 1e-9 * header.stamp.nsecs


def summary_line(poses):
    """The demo's closing line, e.g. 'summary: frames 20, detected 20, aligned 3 (frames 17-19,
    first at 0.572 m)'; frame numbers count from 0 in arrival order."""
    aligned = [i for i, p in enumerate(poses) if p.aligned]
    line = "summary: frames %d, detected %d, aligned %d" % (
        len(poses), sum(bool(p.detected) for p in poses), len(aligned))
    if aligned:
        line += " (frames %d-%d, first at %.3f m)" % (aligned[0], aligned[-1], poses[aligned[0]].distance)
    return line


def image_pixels(msg):
    """A sensor_msgs/Image as a BGR numpy array (a copy), or None for an encoding it cannot show."""
    channels = {"bgr8": 3, "rgb8": 3, "mono8": 1}.get(msg.encoding)
    if channels is None or msg.width == 0 or msg.height == 0:
        return None
    # Rows may be padded (step > width * channels).
    rows = np.frombuffer(msg.data, np.uint8, count=msg.height * msg.step).reshape(msg.height, msg.step)
    pixels = rows[:, :msg.width * channels].reshape(msg.height, msg.width, channels)
    if msg.encoding == "rgb8":
        return cv2.cvtColor(pixels, cv2.COLOR_RGB2BGR)
    if msg.encoding == "mono8":
        return cv2.cvtColor(pixels, cv2.COLOR_GRAY2BGR)
    return pixels.copy()


def thumbnail(pixels, width):
    """pixels scaled to `width` (aspect kept); what the sheet keeps per frame, so that a long
    stream does not hold every full-size overlay in memory."""
    if pixels is None:
        return None
    height = max(1, int(round(pixels.shape[0] * width / float(pixels.shape[1]))))
    if pixels.shape[1] == width and pixels.shape[0] == height:
        return pixels
    return cv2.resize(pixels, (width, height), interpolation=cv2.INTER_AREA)


def frame_state(pose):
    if pose.aligned:
        return "ALIGNED"
    if pose.detected:
        return "detected" if pose.hole_detected else "flange only"
    return "no spool"


def metres(value):
    return "-- m" if value is None or math.isnan(value) else "%.3f m" % value


class SheetLayout(object):
    """Where everything goes on a contact sheet of `count` tiles: `columns` per row, each an
    image of tile_w x tile_h px in a `border` px frame with two label lines below, and a title
    strip across the top."""

    def __init__(self, count, columns=5, tile_w=320, tile_h=240):
        self.count = count
        self.columns = max(1, min(columns, count)) if count else 1
        self.rows = max(1, int(math.ceil(count / float(self.columns))))
        self.tile_w, self.tile_h = tile_w, tile_h
        self.border = max(3, tile_w // 50)
        self.font_scale = max(0.35, tile_w / 640.0)
        self.bold = 2 if self.font_scale >= 0.5 else 1  # thicker strokes blur small text
        self.line_h = int(round(22 * self.font_scale)) + 4
        self.label_h = 2 * self.line_h + 4
        self.gap = max(4, tile_w // 40)
        self.cell_w = tile_w + 2 * self.border
        self.cell_h = tile_h + 2 * self.border + self.label_h
        self.width = self.columns * self.cell_w + (self.columns + 1) * self.gap
        self.title_h = int(round(36 * self.font_scale)) + 2 * self.gap
        self.height = self.title_h + self.rows * self.cell_h + (self.rows + 1) * self.gap

    def cell(self, index):
        """Top-left corner (x, y) of tile `index`'s frame (its border's outer edge)."""
        row, col = divmod(index, self.columns)
        return (self.gap + col * (self.cell_w + self.gap),
                self.title_h + self.gap + row * (self.cell_h + self.gap))


def put_text_fitted(image, text, x, baseline_y, max_width, scale, colour, thickness=1):
    """Text at (x, baseline_y), shrunk until it fits max_width px."""
    while scale > 0.2 and cv2.getTextSize(text, FONT, scale, thickness)[0][0] > max_width:
        scale *= 0.9
    cv2.putText(image, text, (x, baseline_y), FONT, scale, colour, thickness, cv2.LINE_AA)


def contact_sheet(poses, overlays, title, columns=5, tile_width=320):
    """One BGR image: every pose's overlay in order, labelled with its frame index, time from
    the first frame, depth and state; aligned frames framed in ALIGNED_BGR. overlays[i] is pose
    i's overlay as a BGR array (any size) or None (tile says "no overlay")."""
    if len(overlays) != len(poses):
        raise ValueError("%d overlays for %d poses" % (len(overlays), len(poses)))
    shown = [o for o in overlays if o is not None]
    # The tiles take the first overlay's aspect ratio (640x480 -> 4:3).
    aspect = shown[0].shape[0] / float(shown[0].shape[1]) if shown else 0.75
    layout = SheetLayout(len(poses), columns, tile_width, max(1, int(round(tile_width * aspect))))
    sheet = np.full((layout.height, layout.width, 3), BACKGROUND_BGR, np.uint8)
    put_text_fitted(sheet, title, layout.gap, layout.title_h - layout.gap - 4, layout.width - 2 * layout.gap,
                    1.4 * layout.font_scale, TEXT_BGR, layout.bold)
    t0 = stamp_seconds(poses[0].header) if poses else 0.0
    for i, (pose, overlay) in enumerate(zip(poses, overlays)):
        x, y = layout.cell(i)
        b, w, h = layout.border, layout.tile_w, layout.tile_h
        frame_colour = ALIGNED_BGR if pose.aligned else BORDER_BGR
        sheet[y:y + h + 2 * b, x:x + w + 2 * b] = frame_colour
        inner = sheet[y + b:y + b + h, x + b:x + b + w]
        if overlay is None:
            inner[:] = MISSING_BGR
            text_w = cv2.getTextSize("no overlay", FONT, layout.font_scale, 1)[0][0]
            put_text_fitted(sheet, "no overlay", x + b + max(0, (w - text_w) // 2), y + b + h // 2, w,
                            layout.font_scale, TEXT_BGR)
        else:
            inner[:] = cv2.resize(overlay, (w, h), interpolation=cv2.INTER_AREA) \
                if overlay.shape[:2] != (h, w) else overlay
        state = frame_state(pose)
        first = "#%d  t %.2f s" % (i, stamp_seconds(pose.header) - t0)
        second = "%s  %s" % (metres(pose.distance), state)
        label_top = y + h + 2 * b
        put_text_fitted(sheet, first, x + 2, label_top + layout.line_h, layout.cell_w - 4, layout.font_scale, TEXT_BGR)
        put_text_fitted(sheet, second, x + 2, label_top + 2 * layout.line_h, layout.cell_w - 4, layout.font_scale,
                        ALIGNED_BGR if pose.aligned else TEXT_BGR, layout.bold if pose.aligned else 1)
    return sheet


def save_sheet(path, sheet, colours=0):
    """Writes the sheet as PNG; colours (8-256) reduces it to that many palette colours (PIL),
    which makes a README-sized file; 0 keeps full colour."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    if colours == 0:
        if not cv2.imwrite(path, sheet, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
            raise OSError("cannot write %s" % path)
        return
    # A median cut alone spends the palette on the frames' greys and turns the labels' few green
    # and white pixels grey-green: the sheet's own colours are kept exactly, the rest adapts.
    reserved = [ALIGNED_BGR, TEXT_BGR, BORDER_BGR, BACKGROUND_BGR, MISSING_BGR]
    if not len(reserved) + 3 <= colours <= 256:
        raise ValueError("a palette of %d colours: 0 (full colour) or 8-256" % colours)
    from PIL import Image
    rgb = Image.fromarray(cv2.cvtColor(sheet, cv2.COLOR_BGR2RGB))
    adaptive = rgb.quantize(colors=colours - len(reserved), method=Image.Quantize.MEDIANCUT,
                            dither=Image.Dither.NONE)
    palette = adaptive.getpalette()[:3 * (colours - len(reserved))]
    for bgr in reserved:
        palette += list(bgr[::-1])
    target = Image.new("P", (1, 1))
    target.putpalette(palette + [0] * (768 - len(palette)))
    rgb.quantize(palette=target, dither=Image.Dither.NONE).save(path, optimize=True)


# The plotted quantities: (message field, axis label, factor from the message's unit).
PLOT_ROWS = [
    ("distance", "depth [m]", 1.0),
    ("yaw", "bearing yaw [deg]", 180.0 / math.pi),
    ("axis_angle", "axis angle [deg]", 180.0 / math.pi),
    ("aligned", "aligned", 1.0),
]


def number(value, factor):
    """A message value as a float for the plot; bools as 0/1, undefined values stay NaN."""
    if isinstance(value, bool):
        return 1.0 if value else 0.0
    return float(value) * factor


def plot_series(poses):
    """What the plot draws: {"t": seconds from the first frame's stamp, "rows": [(label, raw,
    filtered or None)]}.

    With the node's tracker on (track_state other than TRACK_OFF, 0) each field is the filtered
    estimate and the frame's own detection is beside it as raw_<field> where the message has one
    (raw_distance): those rows draw both, "raw" and "filtered". A field without raw_<field>, or a
    node without the tracker (its raw_distance is the distance itself), gives one series.
    """
    t0 = stamp_seconds(poses[0].header) if poses else 0.0
    with_tracker = bool(poses) and all(getattr(p, "track_state", 0) != 0 for p in poses)
    rows = []
    for field, label, factor in PLOT_ROWS:
        raw_field = "raw_" + field
        tracked = with_tracker and all(hasattr(p, raw_field) for p in poses)
        raw = [number(getattr(p, raw_field if tracked else field), factor) for p in poses]
        filtered = [number(getattr(p, field), factor) for p in poses] if tracked else None
        rows.append((label, raw, filtered))
    return {"t": [stamp_seconds(p.header) - t0 for p in poses], "rows": rows}


def approach_plot(poses, path, title, pyplot):
    """Writes the PLOT_WIDTH_IN x PLOT_HEIGHT_IN plot of plot_series(poses) as PNG: stacked rows
    sharing the time axis, NaN values as gaps, aligned frames shaded green in every row.
    `pyplot` is matplotlib.pyplot on the Agg backend (the caller chooses it)."""
    series = plot_series(poses)
    t = series["t"]
    figure, axes = pyplot.subplots(len(series["rows"]), 1, sharex=True,
                                   figsize=(PLOT_WIDTH_IN, PLOT_HEIGHT_IN), dpi=PLOT_DPI)
    try:
        aligned = [i for i, p in enumerate(poses) if p.aligned]
        # A frame stands for half a frame interval either side, so a single aligned frame shows.
        half = 0.5 * (t[-1] - t[0]) / (len(t) - 1) if len(t) > 1 else 0.05
        for ax, (label, raw, filtered) in zip(axes, series["rows"]):
            for i in aligned:
                ax.axvspan(t[i] - half, t[i] + half, color="tab:green", alpha=0.15, linewidth=0)
            if label == "aligned":
                ax.step(t, raw, where="mid", color="tab:green", linewidth=1.5, label="raw")
                if filtered is not None:
                    ax.step(t, filtered, where="mid", color="tab:orange", linewidth=1.5, label="filtered")
                ax.set_yticks([0, 1])
                ax.set_yticklabels(["no", "yes"])
                ax.set_ylim(-0.2, 1.2)
            else:
                ax.plot(t, raw, "-o", color="tab:blue", markersize=3, linewidth=1.0, label="raw")
                if filtered is not None:
                    ax.plot(t, filtered, "-", color="tab:orange", linewidth=1.8, label="filtered")
                if all(math.isnan(v) for v in raw):
                    ax.text(0.5, 0.5, "nothing detected", transform=ax.transAxes, ha="center", va="center",
                            color="0.4")
            ax.set_ylabel(label)
            ax.grid(True, color="0.9")
            ax.set_axisbelow(True)
        if aligned:
            first = aligned[0]
            # In the bottom row, pointing at the step to "yes" from the side with room for the text.
            left = t[first] - t[0] > 0.4 * (t[-1] - t[0])
            axes[-1].annotate("aligned from t %.2f s at %s" % (t[first], metres(poses[first].distance)),
                              (t[first] - half, 1.0), xytext=(-12 if left else 12, 0), textcoords="offset points",
                              ha="right" if left else "left", va="center", fontsize="small", color="tab:green",
                              arrowprops={"arrowstyle": "->", "color": "tab:green"})
        if any(filtered is not None for _, _, filtered in series["rows"]):
            axes[0].legend(fontsize="small", loc="upper right")
        axes[-1].set_xlabel("time from the first frame [s]")
        figure.suptitle(title, fontsize="medium")
        figure.tight_layout()  # the figure keeps its size and dpi; the axes make room
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        figure.savefig(path)
    finally:
        pyplot.close(figure)
