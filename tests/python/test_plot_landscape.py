"""yamor-plot-landscape (yamor.tools.plot_landscape): the grid plugin's landscape CSV as a heatmap,
with an optimizer's path from an evaluations.csv drawn on it."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

np = pytest.importorskip("numpy")
image = pytest.importorskip("matplotlib.image")

REPO = Path(__file__).resolve().parents[2]
SCRIPT = [sys.executable, "-m", "yamor.tools.plot_landscape"]


def load_module():
    from yamor.tools import plot_landscape  # after the importorskip of matplotlib

    return plot_landscape


def write_landscape(path: Path, nx: int = 9, ny: int = 7) -> None:
    """A grid like the grid plugin writes: x slowest, y fastest."""
    lines = ["offset.5,phase.0.1,value"]
    for i in range(nx):
        x = -math.pi / 2 + i * (math.pi / 2) / (nx - 1)
        for j in range(ny):
            y = j * 2 * math.pi / (ny - 1)
            lines.append(f"{x!r},{y!r},{math.sin(y) * math.cos(2 * x)!r}")
    path.write_text("\n".join(lines) + "\n")


def write_evaluations(path: Path) -> None:
    """An evaluations.csv as yamor-optimize writes it, with other columns around."""
    rows = ["index,phase.0.1,amplitude.0,offset.5,velocity,distance,diverged,host,wall_seconds"]
    points = [(1.0, -1.2), (1.4, -1.2), (1.6, -0.9), (1.55, -0.5), (1.57, -0.1)]
    for k, (phase, offset) in enumerate(points):
        rows.append(f"{k},{phase},0.5,{offset},0.01,0.1,0,local,0.0")
    path.write_text("\n".join(rows) + "\n")


def run(*args):
    return subprocess.run([*SCRIPT, *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def pixels(png: Path):
    return image.imread(str(png))


def test_draws_a_nontrivial_heatmap(tmp_path):
    csv_path, png = tmp_path / "landscape.csv", tmp_path / "landscape.png"
    write_landscape(csv_path)
    r = run(csv_path, png)
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 10_000
    img = pixels(png)
    assert img.shape[0] > 300 and img.shape[1] > 300
    # Many distinct colours (a heatmap, not a blank canvas).
    colours = {tuple(p) for p in (img[::7, ::7, :3] * 255).astype(int).reshape(-1, 3)}
    assert len(colours) > 50


def test_path_is_drawn_on_top(tmp_path):
    csv_path, evaluations = tmp_path / "landscape.csv", tmp_path / "evaluations.csv"
    write_landscape(csv_path)
    write_evaluations(evaluations)
    plain, with_path = tmp_path / "plain.png", tmp_path / "path.png"
    assert run(csv_path, plain, "--title", "t").returncode == 0
    r = run(csv_path, with_path, "--path", evaluations, "--title", "t")
    assert r.returncode == 0, r.stderr
    a, b = pixels(plain), pixels(with_path)
    assert a.shape == b.shape
    assert np.abs(a - b).sum(axis=2).astype(bool).sum() > 200


def test_reads_the_grid_into_a_matrix(tmp_path):
    csv_path = tmp_path / "landscape.csv"
    csv_path.write_text("a,b,value\n0,10,1\n0,20,2\n0,30,3\n1,10,4\n1,20,5\n1,30,6\n")
    x_name, y_name, value_name, xs, ys, values = load_module().read_landscape(csv_path)
    assert (x_name, y_name, value_name) == ("a", "b", "value")
    assert list(xs) == [0.0, 1.0] and list(ys) == [10.0, 20.0, 30.0]
    assert values.tolist() == [[1.0, 4.0], [2.0, 5.0], [3.0, 6.0]]  # values[y][x]


def test_reads_path_columns_by_name(tmp_path):
    evaluations = tmp_path / "evaluations.csv"
    write_evaluations(evaluations)
    xs, ys = load_module().read_path(evaluations, "offset.5", "phase.0.1")
    assert xs == [-1.2, -1.2, -0.9, -0.5, -0.1]
    assert ys == [1.0, 1.4, 1.6, 1.55, 1.57]


def test_path_without_the_parameters_fails(tmp_path):
    csv_path, evaluations = tmp_path / "landscape.csv", tmp_path / "evaluations.csv"
    write_landscape(csv_path)
    evaluations.write_text("index,x0,velocity\n0,1,2\n")
    r = run(csv_path, tmp_path / "out.png", "--path", evaluations)
    assert r.returncode == 1
    assert "'offset.5'" in r.stderr and "'phase.0.1'" in r.stderr and "x0" in r.stderr
    assert not (tmp_path / "out.png").exists()


@pytest.mark.parametrize("text, message", [
    ("", "empty file"),
    ("a,b\n0,1\n", "header"),
    ("a,b,value\n0,0,1\n0,1,x\n", "not a number"),
    ("a,b,value\n0,0,1\n0,1,2\n", "at least 2 distinct"),
])
def test_malformed_landscape_fails_with_a_message(tmp_path, text, message):
    csv_path = tmp_path / "landscape.csv"
    csv_path.write_text(text)
    r = run(csv_path, tmp_path / "out.png")
    assert r.returncode == 1
    assert message in r.stderr, r.stderr


def test_incomplete_grid_still_draws(tmp_path):
    # A grid stopped by its budget has holes; they are drawn as blanks.
    csv_path, png = tmp_path / "landscape.csv", tmp_path / "out.png"
    csv_path.write_text("a,b,value\n0,0,1\n0,1,2\n0,2,3\n1,0,4\n1,1,5\n")
    r = run(csv_path, png)
    assert r.returncode == 0, r.stderr
    assert png.stat().st_size > 5_000
