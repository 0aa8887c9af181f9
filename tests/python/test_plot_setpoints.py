"""yamor-plot-setpoints (yamor.tools.plot_setpoints): yamor-cpg-run's servo set-points, one
trace per module, a disabled CPG drawn as a gap."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

image = pytest.importorskip("matplotlib.image")

from yamor.tools import plot_setpoints  # noqa: E402  (needs matplotlib)

REPO = Path(__file__).resolve().parents[2]
COMMAND = [sys.executable, "-m", "yamor.tools.plot_setpoints"]
CPG_RUN = Path(os.environ.get("YAMOR_CPG_RUN", REPO / "build" / "release" / "cpg" / "yamor-cpg-run"))


def run(*args):
    return subprocess.run([*COMMAND, *map(str, args)], capture_output=True, text=True, timeout=120)


def test_an_empty_cell_is_a_gap(tmp_path):
    csv_path = tmp_path / "setpoints.csv"
    csv_path.write_text("time,0,3\n0,0.1,0.2\n0.01,,0.25\n0.02,0.3,\n")
    times, series = plot_setpoints.read_setpoints(csv_path)
    assert times == [0.0, 0.01, 0.02]
    assert list(series) == ["0", "3"]
    assert series["0"][0] == 0.1 and math.isnan(series["0"][1]) and series["0"][2] == 0.3
    assert series["3"][:2] == [0.2, 0.25] and math.isnan(series["3"][2])


@pytest.mark.parametrize("text, message", [
    ("", "empty file"),
    ("step,0\n1,0.1\n", "expected a header 'time,<id>,...'"),
    ("time,0,1\n0,0.1\n", ":2: 2 cells, header has 3"),
])
def test_a_malformed_file_is_refused_naming_the_problem(tmp_path, text, message):
    csv_path = tmp_path / "setpoints.csv"
    csv_path.write_text(text)
    result = run(csv_path, tmp_path / "s.png")
    assert result.returncode == 1
    assert message in result.stderr
    assert not (tmp_path / "s.png").exists()


def test_draws_what_yamor_cpg_run_writes(tmp_path):
    if not CPG_RUN.is_file():
        pytest.skip(f"yamor-cpg-run not built: {CPG_RUN}")
    csv_path, png = tmp_path / "setpoints.csv", tmp_path / "setpoints.png"
    subprocess.run([str(CPG_RUN), "--config", str(REPO / "configs" / "robots" / "quadruped.xml"),
                    "--out", str(csv_path), "--duration", "5", "--log-level", "warn"],
                   check=True, capture_output=True, timeout=120)
    times, series = plot_setpoints.read_setpoints(csv_path)
    assert len(series) == 9 and times[-1] == pytest.approx(5.0, abs=0.011)
    result = run(csv_path, png, "--title", "quadruped")
    assert result.returncode == 0, result.stderr
    pixels = image.imread(png)
    assert pixels.shape[:2] == (605, 1210)  # 11 x 5.5 in at 110 dpi
    assert pixels[..., :3].std() > 0.05, "something is drawn"


def test_an_unwritable_image_fails_naming_it(tmp_path):
    csv_path = tmp_path / "setpoints.csv"
    csv_path.write_text("time,0\n0,0.1\n0.01,0.2\n")
    png = tmp_path / "no-such-folder" / "s.png"
    result = run(csv_path, png)
    assert result.returncode == 1
    assert f"cannot write {png}" in result.stderr
