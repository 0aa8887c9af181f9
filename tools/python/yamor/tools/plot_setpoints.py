"""Plots the servo set-points written by yamor-cpg-run.

Usage: yamor-plot-setpoints CSV PNG [--title TITLE]

The CSV has a header `time,<id>,<id>,...` and one row per sample; an empty
cell means the module's CPG was disabled at that time (drawn as a gap).
"""
import argparse
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (backend must be chosen first)


def read_setpoints(path):
    """Returns (times, {module id: [set-point or NaN]}) in header order."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        try:
            header = next(reader)
        except StopIteration:
            raise ValueError(f"{path}: empty file") from None
        if not header or header[0] != "time" or len(header) < 2:
            raise ValueError(f"{path}: expected a header 'time,<id>,...', got {header!r}")
        ids = header[1:]
        times = []
        series = {module: [] for module in ids}
        for line_number, row in enumerate(reader, start=2):
            if len(row) != len(header):
                raise ValueError(
                    f"{path}:{line_number}: {len(row)} cells, header has {len(header)}")
            times.append(float(row[0]))
            for module, cell in zip(ids, row[1:]):
                series[module].append(float(cell) if cell != "" else math.nan)
    return times, series


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", help="set-point CSV from yamor-cpg-run")
    parser.add_argument("png", help="output image")
    parser.add_argument("--title", default=None, help="plot title")
    args = parser.parse_args(argv)

    try:
        times, series = read_setpoints(args.csv)
    except (OSError, ValueError) as error:
        print(f"plot_setpoints: {error}", file=sys.stderr)
        return 1

    fig, ax = plt.subplots(figsize=(11, 5.5), dpi=110)
    for module, values in series.items():
        ax.plot(times, values, linewidth=1.2, label=f"module {module}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("servo set-point [rad]")
    ax.set_title(args.title or f"CPG set-points ({args.csv})")
    ax.grid(True, alpha=0.3)
    if times:
        ax.set_xlim(times[0], times[-1])
    # Outside the axes so it never hides a trace.
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", frameon=False)
    fig.tight_layout()
    try:
        fig.savefig(args.png)
    except OSError as error:
        print(f"plot_setpoints: cannot write {args.png}: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
