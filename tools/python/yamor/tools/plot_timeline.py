"""Plots a yamor-lifelong run like thesis Figure 7.4: velocity over time, events marked.

Usage: yamor-plot-timeline TIMELINE_CSV PNG [--title TITLE]

TIMELINE_CSV is yamor-lifelong's timeline.csv: a header
`time,velocity,ema,state,event,gait` and one row per measurement window or
trial (velocity set) or event (velocity empty). Time is drawn in minutes,
velocities in cm/s. Walking windows are a line, recall and relearning trials
dots, the stored velocity (EMA) a thin line; anomalies are vertical red
lines, daemon gaps grey spans.
"""
import argparse
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (backend must be chosen first)

COLUMNS = ("time", "velocity", "ema", "state", "event", "gait")
STATE_STYLE = {
    "walking": ("tab:blue", "walking"),
    "recalling": ("tab:orange", "recall trial"),
    "relearning": ("tab:gray", "relearning trial"),
    "anomaly": ("tab:red", "anomaly"),
}


def number(text):
    return float(text) if text != "" else math.nan


def read_timeline(path):
    """Returns a list of dicts with time [s], velocity and ema [m/s], state, event."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        try:
            header = next(reader)
        except StopIteration:
            raise ValueError(f"{path}: empty file") from None
        if tuple(header) != COLUMNS:
            raise ValueError(f"{path}: header {header!r} is not {','.join(COLUMNS)}")
        rows = []
        for line_number, row in enumerate(reader, start=2):
            if len(row) != len(COLUMNS):
                raise ValueError(f"{path}:{line_number}: {len(row)} cells, expected {len(COLUMNS)}")
            rows.append({"time": number(row[0]), "velocity": number(row[1]), "ema": number(row[2]),
                         "state": row[3], "event": row[4]})
    return rows


def plot(rows, png, title):
    fig, ax = plt.subplots(figsize=(10, 4.5))
    minutes = lambda r: r["time"] / 60.0  # noqa: E731
    measured = [r for r in rows if not math.isnan(r["velocity"])]
    # Walking windows (and the stored velocity) as lines broken wherever
    # something else happened.
    segments, segment = [], []
    for r in rows:
        if r["state"] == "walking" and not math.isnan(r["velocity"]):
            segment.append(r)
        elif segment:
            segments.append(segment)
            segment = []
    if segment:
        segments.append(segment)
    for k, seg in enumerate(segments):
        ax.plot([minutes(s) for s in seg], [100 * s["velocity"] for s in seg], color="tab:blue",
                linewidth=1.5, label="walking" if k == 0 else None)
        ema = [s for s in seg if not math.isnan(s["ema"])]
        if ema:
            ax.plot([minutes(s) for s in ema], [100 * s["ema"] for s in ema], color="tab:green",
                    linewidth=0.8, alpha=0.8, label="stored velocity (EMA)" if k == 0 else None)
    for state in ("recalling", "relearning"):
        points = [r for r in measured if r["state"] == state]
        if points:
            color, label = STATE_STYLE[state]
            ax.scatter([minutes(r) for r in points], [100 * r["velocity"] for r in points], s=10,
                       color=color, alpha=0.7, label=label)
    labelled = set()
    lost = None
    for r in rows:
        event = r["event"]
        if event.startswith("anomaly"):
            ax.axvline(minutes(r), color="tab:red", linewidth=1,
                       label=None if "anomaly" in labelled else "anomaly")
            ax.annotate(event.replace("anomaly: ", ""), (minutes(r), 1.0), xycoords=("data", "axes fraction"),
                        rotation=90, va="top", ha="right", fontsize=7, color="tab:red")
            labelled.add("anomaly")
        elif event == "daemon lost":
            lost = r["time"]
        elif event.startswith("reattached") and lost is not None:
            ax.axvspan(lost / 60.0, minutes(r), color="0.85",
                       label=None if "gap" in labelled else "daemon away")
            labelled.add("gap")
            lost = None
    ax.set_xlabel("time [min]")
    ax.set_ylabel("velocity [cm/s]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv")
    parser.add_argument("png")
    parser.add_argument("--title", default="yamor-lifelong")
    args = parser.parse_args(argv)
    try:
        rows = read_timeline(args.csv)
    except (OSError, ValueError) as e:
        print(f"plot_timeline: {e}", file=sys.stderr)
        return 1
    if not any(not math.isnan(r["velocity"]) for r in rows):
        print(f"plot_timeline: {args.csv}: no measurement to plot", file=sys.stderr)
        return 1
    plot(rows, args.png, args.title)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
