"""yamor-plot-timeline (yamor.tools.plot_timeline): a yamor-lifelong timeline.csv drawn like thesis Figure 7.4."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

image = pytest.importorskip("matplotlib.image")

REPO = Path(__file__).resolve().parents[2]
SCRIPT = [sys.executable, "-m", "yamor.tools.plot_timeline"]
HEADER = "time,velocity,ema,state,event,gait"


def write_timeline(path: Path) -> None:
    """Walking, an anomaly, relearning trials, walking again, a daemon gap."""
    rows = [HEADER]
    t = 0.0
    for _ in range(20):
        t += 10
        rows.append(f"{t},0.05,0.05,walking,,1")
    rows.append(f"{t},,0.05,anomaly,\"anomaly: module_disconnected\",1")
    for k in range(30):
        t += 13
        rows.append(f"{t},{0.01 + 0.001 * k},0.05,relearning,,1")
    for _ in range(10):
        t += 10
        rows.append(f"{t},0.045,,walking,,2")
    rows.append(f"{t},,0.045,disconnected,daemon lost,2")
    rows.append(f"{t + 30},,0.045,walking,reattached after 12.3 s,2")
    rows.append(f"{t + 40},0.044,0.045,walking,,2")
    path.write_text("\n".join(rows) + "\n")


def run(*args):
    return subprocess.run([*SCRIPT, *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def test_draws_the_figure(tmp_path):
    csv_path, png = tmp_path / "timeline.csv", tmp_path / "timeline.png"
    write_timeline(csv_path)
    r = run(csv_path, png, "--title", "test")
    assert r.returncode == 0, r.stderr
    pixels = image.imread(str(png))
    assert pixels.shape[0] > 300 and pixels.shape[1] > 600
    assert pixels[..., :3].std() > 0.05  # not blank


def test_refuses_another_csv(tmp_path):
    csv_path, png = tmp_path / "x.csv", tmp_path / "x.png"
    csv_path.write_text("index,velocity\n0,0.1\n")
    r = run(csv_path, png)
    assert r.returncode == 1
    assert "header" in r.stderr
    assert not png.exists()


def test_refuses_a_timeline_without_measurements(tmp_path):
    csv_path, png = tmp_path / "timeline.csv", tmp_path / "timeline.png"
    csv_path.write_text(HEADER + "\n1,,,walking,daemon lost,1\n")
    r = run(csv_path, png)
    assert r.returncode == 1
    assert "no measurement" in r.stderr
