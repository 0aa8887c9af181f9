"""Plots an optimization run: the velocity of every evaluation and the best so far.

Usage: yamor-plot-progress EVALUATIONS_CSV PNG [--title TITLE]

EVALUATIONS_CSV is yamor-optimize's evaluations.csv: a header
`index,<parameter>...,velocity,distance,diverged,host,wall_seconds` and one
row per evaluation in submission order. Velocities are m/s in the file and
drawn in cm/s. Diverged evaluations are marked.
"""
import argparse
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (backend must be chosen first)


def read_evaluations(path):
    """Returns (indices, velocities [m/s], diverged flags)."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        try:
            header = next(reader)
        except StopIteration:
            raise ValueError(f"{path}: empty file (no evaluation yet)") from None
        for column in ("index", "velocity", "diverged"):
            if column not in header:
                raise ValueError(f"{path}: no '{column}' column in the header {header!r}")
        i_index, i_velocity, i_diverged = (header.index(c) for c in ("index", "velocity", "diverged"))
        indices, velocities, diverged = [], [], []
        for line_number, row in enumerate(reader, start=2):
            if len(row) != len(header):
                raise ValueError(f"{path}:{line_number}: {len(row)} cells, header has {len(header)}")
            indices.append(int(row[i_index]))
            velocities.append(float(row[i_velocity]))
            diverged.append(row[i_diverged] == "1")
    return indices, velocities, diverged


def plot(indices, velocities, diverged, png, title):
    best, best_so_far = None, []
    for v in velocities:
        best = v if best is None or v > best else best
        best_so_far.append(best)
    cm = [100.0 * v for v in velocities]
    fig, ax = plt.subplots(figsize=(9, 4.5))
    ax.scatter(indices, cm, s=8, color="tab:blue", alpha=0.6, label="evaluation")
    ax.plot(indices, [100.0 * b for b in best_so_far], color="tab:red", linewidth=2,
            label="best so far")
    bad = [(i, v) for i, v, d in zip(indices, cm, diverged) if d]
    if bad:
        ax.scatter(*zip(*bad), marker="x", color="black", label="diverged")
    ax.set_xlabel("evaluation")
    ax.set_ylabel("velocity [cm/s]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv")
    parser.add_argument("png")
    parser.add_argument("--title", default="Optimization progress")
    args = parser.parse_args(argv)
    try:
        indices, velocities, diverged = read_evaluations(args.csv)
    except (OSError, ValueError) as e:
        print(f"plot_progress: {e}", file=sys.stderr)
        return 1
    if not indices:
        print(f"plot_progress: {args.csv}: no evaluation to plot", file=sys.stderr)
        return 1
    plot(indices, velocities, diverged, args.png, args.title)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
