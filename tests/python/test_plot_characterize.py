"""yamor-plot-characterize (yamor.tools.plot_characterize): yamor-characterize's CSV files
drawn as thesis appendix B's figures."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

image = pytest.importorskip("matplotlib.image")

from yamor.tools import plot_characterize  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
COMMAND = [sys.executable, "-m", "yamor.tools.plot_characterize"]
CHARACTERIZE = Path(os.environ.get(
    "YAMOR_CHARACTERIZE", REPO / "build" / "release" / "tools" / "characterize" / "yamor-characterize"))


def run(*args):
    return subprocess.run([*COMMAND, *map(str, args)], capture_output=True, text=True, timeout=120)


@pytest.fixture
def data(tmp_path):
    """yamor-characterize's noise data and its sine move."""
    if not CHARACTERIZE.is_file():
        pytest.skip(f"yamor-characterize not built: {CHARACTERIZE}")
    folder = tmp_path / "data"
    for command in (["noise"], ["moves", "--move", "sine"]):
        subprocess.run([str(CHARACTERIZE), *command, "--out", str(folder), "--seed", "3"],
                       check=True, capture_output=True, timeout=120)
    return folder


def test_draws_the_noise_figures_and_the_move_figures(data, tmp_path):
    out = tmp_path / "figures"
    result = run(data, "--out", out)
    assert result.returncode == 0, result.stderr
    assert f"wrote 7 figures to {out}" in result.stdout
    # B.1 the noise, B.2-B.4 its histograms, B.5-B.7 the sine move's accelerations,
    # velocities and positions; written through a temporary name.
    assert sorted(p.name for p in out.iterdir()) == sorted(f"figB-{n}.png" for n in range(1, 8))
    assert image.imread(out / "figB-1.png").shape[:2] == (660, 880)  # 8 x 6 in at 110 dpi
    assert image.imread(out / "figB-2.png").shape[:2] == (440, 770)
    assert image.imread(out / "figB-6.png").shape[:2] == (770, 880)


def test_without_out_the_figures_go_beside_the_data(data):
    assert run(data).returncode == 0
    assert (data / "figB-5.png").exists() and (data / "figB-4.png").exists()


def test_a_folder_without_its_files_draws_nothing(tmp_path):
    result = run(tmp_path)
    assert result.returncode == 1
    assert f"no yamor-characterize CSV in {tmp_path}" in result.stderr


def test_a_cell_that_is_not_a_number_names_file_line_and_column(tmp_path):
    path = tmp_path / "noise.csv"
    path.write_text("time,noise_x,noise_y,noise_z\n0,0.1,0.2,0.3\n0.01,0.1,oops,0.3\n")
    with pytest.raises(SystemExit, match=f"{path}:3: column 'noise_y': not a number: 'oops'"):
        plot_characterize.read_columns(path)
