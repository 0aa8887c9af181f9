"""Draws a two-parameter landscape written by the grid plugin as a heatmap.

Usage: yamor-plot-landscape LANDSCAPE_CSV PNG [--path EVALUATIONS_CSV] [--title TITLE]
                         [--label LABEL]

The landscape CSV (the grid plugin's `landscape_csv`) has a header
`<x name>,<y name>,value` and one row per grid point. The heatmap is drawn
like the thesis's Figure 6.3: red for the highest values, dark blue for the
lowest, smoothly interpolated between the measured points, with contour
lines.

--path overlays an optimizer's path (thesis Figures 6.5-6.7): the
evaluations.csv of a run over the same two parameters; the columns named like
the landscape's x and y parameters are read in row order and drawn as a line
with markers, the first point marked as the start.
"""
import argparse
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (backend must be chosen first)
import numpy as np  # noqa: E402


def read_landscape(path):
    """Returns (x_name, y_name, value_name, xs, ys, values) with xs and ys the
    sorted distinct coordinates and values[j][i] the value at (xs[i], ys[j])
    (NaN where the CSV has no row)."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        try:
            header = next(reader)
        except StopIteration:
            raise ValueError(f"{path}: empty file") from None
        if len(header) != 3:
            raise ValueError(f"{path}: expected a header '<x name>,<y name>,value', got {header!r}")
        rows = []
        for line_number, row in enumerate(reader, start=2):
            if not row:
                continue
            if len(row) != 3:
                raise ValueError(f"{path}:{line_number}: {len(row)} cells, expected 3")
            try:
                x, y, v = (float(cell) for cell in row)
            except ValueError:
                raise ValueError(f"{path}:{line_number}: not a number in {row!r}") from None
            if not all(math.isfinite(c) for c in (x, y, v)):
                raise ValueError(f"{path}:{line_number}: non-finite value in {row!r}")
            rows.append((x, y, v))
    xs = sorted({r[0] for r in rows})
    ys = sorted({r[1] for r in rows})
    if len(xs) < 2 or len(ys) < 2:
        raise ValueError(f"{path}: a landscape needs at least 2 distinct values of each parameter "
                         f"(has {len(xs)} x {len(ys)})")
    column = {x: i for i, x in enumerate(xs)}
    line = {y: j for j, y in enumerate(ys)}
    values = np.full((len(ys), len(xs)), np.nan)
    for x, y, v in rows:
        values[line[y], column[x]] = v
    return header[0], header[1], header[2], np.array(xs), np.array(ys), values


def read_path(path, x_name, y_name):
    """The (x, y) columns named `x_name` and `y_name` of an evaluations CSV, in row order."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        columns = reader.fieldnames or []
        missing = [name for name in (x_name, y_name) if name not in columns]
        if missing:
            raise ValueError(f"{path}: no column {', '.join(repr(m) for m in missing)} "
                             f"(columns: {', '.join(columns)})")
        xs, ys = [], []
        for line_number, row in enumerate(reader, start=2):
            try:
                xs.append(float(row[x_name]))
                ys.append(float(row[y_name]))
            except (TypeError, ValueError):
                raise ValueError(f"{path}:{line_number}: not a number in {x_name!r} or {y_name!r}") from None
    if not xs:
        raise ValueError(f"{path}: no evaluation rows")
    return xs, ys


def draw(landscape, png, path=None, title=None, label=None):
    """Writes the heatmap of `landscape` (with `path`'s points) to `png`."""
    x_name, y_name, value_name, xs, ys, values = read_landscape(landscape)
    path_points = read_path(path, x_name, y_name) if path else None

    fig, ax = plt.subplots(figsize=(8, 6.5), dpi=110)
    complete = not np.isnan(values).any()
    # Gouraud shading interpolates between the measured points over exactly
    # the swept domain (the thesis drew a cubic interpolation); it cannot
    # show holes, so an incomplete grid is drawn cell by cell.
    mesh = ax.pcolormesh(xs, ys, np.ma.masked_invalid(values), cmap="jet",
                         shading="gouraud" if complete else "nearest")
    if complete and len(xs) >= 3 and len(ys) >= 3 and np.ptp(values) > 0:
        ax.contour(xs, ys, values, levels=10, colors="black", linewidths=0.5, alpha=0.35,
                   linestyles="solid")
    fig.colorbar(mesh, ax=ax, label=label or value_name)
    if path_points:
        px, py = path_points
        ax.plot(px, py, "-o", color="white", markeredgecolor="black", markersize=3.5, linewidth=1.2,
                label=f"path ({len(px)} evaluations)")
        # clip_on=False: a start on the domain's edge (a bound) stays whole.
        ax.plot(px[0], py[0], marker="*", markersize=16, color="lime", markeredgecolor="black",
                linestyle="none", label="start", clip_on=False, zorder=5)
        ax.plot(px[-1], py[-1], marker="X", markersize=11, color="white", markeredgecolor="black",
                linestyle="none", label="last", clip_on=False, zorder=5)
        ax.legend(loc="upper right", fontsize="small", framealpha=0.8)
    ax.set_xlim(xs[0], xs[-1])
    ax.set_ylim(ys[0], ys[-1])
    ax.set_xlabel(x_name)
    ax.set_ylabel(y_name)
    ax.set_title(title or f"{value_name} over {x_name} and {y_name} ({len(xs)} x {len(ys)} points)")
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("landscape", help="landscape CSV written by the grid plugin (landscape_csv)")
    parser.add_argument("png", help="output image")
    parser.add_argument("--path", default=None,
                        help="evaluations.csv of a run over the same two parameters, drawn on top")
    parser.add_argument("--title", default=None, help="plot title")
    parser.add_argument("--label", default=None, help="colour bar label (default: the CSV's value column)")
    args = parser.parse_args(argv)

    try:
        draw(args.landscape, args.png, path=args.path, title=args.title, label=args.label)
    except (OSError, ValueError) as error:
        print(f"plot_landscape: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
