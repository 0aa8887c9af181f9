"""Draws thesis appendix B's figures from yamor-characterize's CSV files.

Usage: yamor-plot-characterize DIR [--out FIGDIR]

  DIR/noise.csv, DIR/histogram.csv   -> figB-1.png (noise signal), figB-2..4.png (histograms)
  DIR/<move>.csv for each move       -> figB-<n>.png accelerations, velocities, positions

Blue: the LED tracker (ground truth quantised to 3.3 mm, differentiated for
velocity and acceleration); black: the noise-filtered accelerometer data;
red: the fully filtered data (window, movement end), as in appendix B.
Each figure is written through a temporary name and a rename.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
from pathlib import Path

# Appendix B's figure numbers: (accelerations, velocities, positions) per move.
MOVE_FIGURES = {
    "sine": (5, 6, 7), "circle": (8, 9, 10), "go-and-return": (11, 12, 13),
    "random": (14, 15, 16), "drop": (17, 18, 19),
}
QUANTITIES = [("acceleration", "m/s²", "Accelerations"), ("velocity", "m/s", "Velocities"),
              ("position", "m", "Positions")]
CURVES = [("tracker", "tab:blue", "LED tracker"), ("noise_filtered", "black", "noise filter"),
          ("filtered", "tab:red", "all filters")]


def read_columns(path: Path) -> dict[str, list[float]]:
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        columns: dict[str, list] = {name: [] for name in reader.fieldnames or []}
        for line, row in enumerate(reader, start=2):
            for name, value in row.items():
                try:
                    columns[name].append(float(value) if name != "axis" else value)
                except (TypeError, ValueError):
                    raise SystemExit(f"{path}:{line}: column {name!r}: not a number: {value!r}")
    return columns


def save(fig, path: Path) -> None:
    partial = path.with_suffix(".partial.png")
    fig.savefig(partial, dpi=110)
    os.replace(partial, path)


def noise_figures(plt, data: Path, out: Path) -> list[Path]:
    written = []
    noise = read_columns(data / "noise.csv")
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 6))
    for ax, axis in zip(axes, "xyz"):
        ax.plot(noise["time"], noise[f"noise_{axis}"], lw=0.6, color="black")
        ax.set_ylabel(f"{axis.upper()} [m/s²]")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Figure B.1: noise of the accelerometers (simulated)")
    save(fig, out / "figB-1.png")
    plt.close(fig)
    written.append(out / "figB-1.png")
    hist = read_columns(data / "histogram.csv")
    for number, axis in zip((2, 3, 4), "xyz"):
        rows = [(v, c) for a, v, c in zip(hist["axis"], hist["noise"], hist["count"]) if a == axis]
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.bar([v for v, _ in rows], [c for _, c in rows], width=0.0395 * 0.9, color="tab:blue")
        ax.set_xlabel("noise [m/s²]")
        ax.set_ylabel("occurrences")
        ax.set_title(f"Figure B.{number}: noise probability distribution, {axis.upper()} axis")
        path = out / f"figB-{number}.png"
        save(fig, path)
        plt.close(fig)
        written.append(path)
    return written


def move_figures(plt, data: Path, out: Path) -> list[Path]:
    written = []
    for move, numbers in MOVE_FIGURES.items():
        path = data / f"{move}.csv"
        if not path.exists():
            continue
        cols = read_columns(path)
        for number, (quantity, unit, title) in zip(numbers, QUANTITIES):
            fig, axes = plt.subplots(3, 1, sharex=True, sharey=True, figsize=(8, 7))
            for ax, axis in zip(axes, "xyz"):
                for curve, color, label in CURVES:
                    ax.plot(cols["time"], cols[f"{curve}_{quantity}_{axis}"], color=color,
                            lw=0.8, label=label)
                ax.set_ylabel(f"{axis.upper()} [{unit}]")
            axes[0].legend(loc="best", fontsize=8)
            axes[-1].set_xlabel("time [s]")
            fig.suptitle(f"Figure B.{number}: {title.lower()} for the {move} move (simulated)")
            target = out / f"figB-{number}.png"
            save(fig, target)
            plt.close(fig)
            written.append(target)
    return written


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", help="yamor-characterize output folder")
    parser.add_argument("--out", default=None, help="figure folder (default: DATA)")
    args = parser.parse_args(argv)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_characterize: matplotlib is not installed (make deps); no figures",
              file=sys.stderr)
        return 2
    data = Path(args.data)
    out = Path(args.out) if args.out else data
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if (data / "noise.csv").exists():
        written += noise_figures(plt, data, out)
    written += move_figures(plt, data, out)
    if not written:
        print(f"plot_characterize: no yamor-characterize CSV in {data}", file=sys.stderr)
        return 1
    print(f"plot_characterize: wrote {len(written)} figures to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
