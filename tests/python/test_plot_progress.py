"""yamor-plot-progress (yamor.tools.plot_progress): an optimization's evaluations.csv drawn
as every evaluation's velocity and the best so far; also through the source-tree path
tools/plot/plot_progress.py that yamor-optimize runs for its progress.png."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

image = pytest.importorskip("matplotlib.image")

from yamor.tools import plot_progress  # noqa: E402  (needs matplotlib)

REPO = Path(__file__).resolve().parents[2]
COMMAND = [sys.executable, "-m", "yamor.tools.plot_progress"]
HEADER = "index,amplitude.0,velocity,distance,diverged,host,wall_seconds"


def write_evaluations(path: Path, rows: int = 12) -> None:
    """What yamor-optimize writes; evaluation 5 diverged."""
    lines = [HEADER]
    for i in range(rows):
        lines.append(f"{i},{0.1 * i!r},{0.002 * i + (0.01 if i % 3 == 0 else 0.0)!r},"
                     f"{0.024 * i!r},{int(i == 5)},127.0.0.1:2224,0.5")
    path.write_text("\n".join(lines) + "\n")


def run(*args, command=COMMAND, **kwargs):
    return subprocess.run([*command, *map(str, args)], capture_output=True, text=True,
                          timeout=120, **kwargs)


def test_reads_the_velocity_and_diverged_columns(tmp_path):
    csv_path = tmp_path / "evaluations.csv"
    write_evaluations(csv_path, rows=4)
    indices, velocities, diverged = plot_progress.read_evaluations(csv_path)
    assert indices == [0, 1, 2, 3]
    assert velocities == pytest.approx([0.01, 0.002, 0.004, 0.016])
    assert diverged == [False, False, False, False]


@pytest.mark.parametrize("text, message", [
    ("", "empty file (no evaluation yet)"),
    ("index,velocity,host\n0,0.1,h\n", "no 'diverged' column"),
    (HEADER + "\n0,0.1,0.01,0.1,0\n", ":2: 5 cells, header has 7"),
])
def test_a_malformed_file_is_refused_naming_the_problem(tmp_path, text, message):
    csv_path = tmp_path / "evaluations.csv"
    csv_path.write_text(text)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        plot_progress.read_evaluations(csv_path)
    result = run(csv_path, tmp_path / "p.png")
    assert result.returncode == 1 and message in result.stderr
    assert not (tmp_path / "p.png").exists()


def test_draws_the_figure(tmp_path):
    csv_path, png = tmp_path / "evaluations.csv", tmp_path / "progress.png"
    write_evaluations(csv_path)
    result = run(csv_path, png, "--title", "quadruped-7")
    assert result.returncode == 0, result.stderr
    pixels = image.imread(png)
    assert pixels.shape[:2] == (495, 990)  # 9 x 4.5 in at 110 dpi
    assert pixels[..., :3].std() > 0.05, "something is drawn"


def test_a_header_without_rows_draws_nothing(tmp_path):
    csv_path = tmp_path / "evaluations.csv"
    csv_path.write_text(HEADER + "\n")
    result = run(csv_path, tmp_path / "p.png")
    assert result.returncode == 1
    assert "no evaluation to plot" in result.stderr


@pytest.mark.parametrize("path", ["tools/plot/plot_progress.py", "tools/plot/plot_timeline.py"])
def test_the_source_tree_paths_yamor_optimize_and_lifelong_run_need_no_package(tmp_path, path):
    # -I: no PYTHONPATH, no current folder; the file finds its module by itself.
    result = run("--help", command=[sys.executable, "-I", str(REPO / path)], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "usage:" in result.stdout
    csv_path, png = tmp_path / "evaluations.csv", tmp_path / "progress.png"
    write_evaluations(csv_path)
    if path.endswith("plot_progress.py"):
        result = run(csv_path, png, command=[sys.executable, "-I", str(REPO / path)], cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        assert image.imread(png).shape[:2] == (495, 990)
