"""yamor-generated-bench (yamor.tools.generated_bench) in --quick mode, and its script-to-morphology helper.

The smoke test runs the real build (yamord, yamor-optimize, powell.so,
yamor-cpg-build, yamorctl) with tiny settings (budget 4, 1 s warm-up + 2 s
walk, one seed) on two running daemons and checks the table and CSV files.
The build is $YAMOR_BUILD, else the one $YAMORD lives in (build/release).
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from conftest import REPO, YAMORD

from yamor.launcher import start_daemons
from yamor.tools import generated_bench

BUILD = Path(os.environ.get("YAMOR_BUILD", YAMORD.parent.parent))
BENCH = [sys.executable, "-m", "yamor.tools.generated_bench"]


def load_bench():
    return generated_bench
    return module


def test_the_quadruped_script_moves_two_knees_to_the_ends_of_two_legs():
    bench = load_bench()
    before = (REPO / "configs" / "worlds" / "quadruped.xml").read_text()
    after = ET.fromstring(bench.apply_script(before, bench.TRANSFORM_SCRIPT))
    edges = {(c.get("idfrom"), c.get("idto"), c.get("angle")) for c in after.iter("connect")}
    assert ("7", "2", "270") not in edges and ("8", "3", "270") not in edges
    assert ("7", "5", "0") in edges and ("8", "6", "0") in edges
    assert len(edges) == 8 and len(after.findall("module")) == 9


def test_parse_args_defaults_and_robot_selection(capsys):
    bench = load_bench()
    args = bench.parse_args([])
    assert (args.seeds, args.robot_seeds, args.budget, args.checkpoints) == (3, 3, 300, [100])
    assert args.robots == bench.ROBOTS and args.check_seeds == [1, 2, 3]
    assert bench.parse_args(["--robots", "wheel,snake"]).robots == ["snake", "wheel"]  # one order
    assert bench.parse_args(["--robots", "none"]).robots == []
    with pytest.raises(SystemExit):
        bench.parse_args(["--robots", "octopus"])
    assert "unknown octopus" in capsys.readouterr().err


def test_generated_bench_quick_writes_the_tables(tmp_path):
    for path in (BUILD / "host" / "yamord", BUILD / "optimizer-plugins" / "yamor-optimize",
                 BUILD / "plugins" / "powell.so", BUILD / "tools" / "cpg_build" / "yamor-cpg-build",
                 BUILD / "tools" / "yamorctl" / "yamorctl"):
        if not path.exists():
            pytest.skip(f"not built: {path} (make build, or set YAMOR_BUILD)")
    with start_daemons(2, BUILD / "host" / "yamord", ["--workers", "1", "--log-level", "warn"],
                       log_dir=tmp_path / "logs") as pool:
        result = subprocess.run([*BENCH, "--quick", "--robots", "wheel,quadruped-transformed",
                                 "--timing-runs", "1", "--quiet", "--hosts", pool.hosts_arg(),
                                 "--build", str(BUILD), "--out", str(tmp_path)],
                                cwd=REPO, capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
        assert pool.running()  # --hosts: left running
    text = (tmp_path / "generated-bench.md").read_text()
    assert text in result.stdout
    assert "## (a) Quadruped" in text and "Generated / hand-made median best after 4" in text
    rows = [line.split("|")[1].strip() for line in text.splitlines()
            if line.startswith("| ") and "---" not in line]
    assert rows == ["problem", "hand-made", "generated", "robot", "quadruped", "wheel", "quadruped-transformed"]
    with open(tmp_path / "runs.csv", newline="") as f:
        runs = list(csv.DictReader(f))
    assert [r["problem"] for r in runs] == ["quadruped-hand-made", "quadruped", "wheel", "quadruped-transformed"]
    assert all(r["status"] == "budget" and r["evaluations"] == "4" for r in runs)
    assert (tmp_path / "problems" / "quadruped-transformed.morphology.xml").exists()
    with open(tmp_path / "cpg-build-times.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == 3  # quadruped, wheel, transformed; 1 run each
