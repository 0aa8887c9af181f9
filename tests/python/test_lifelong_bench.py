"""yamor-lifelong-bench (yamor.tools.lifelong_bench): its options, and its --quick run of three parts.

The smoke test runs the real build (yamord, yamor-lifelong, yamor-optimize,
powell.so, cmaes.so, yamorctl) with tiny settings (budgets of 3-6, windows
of 2 periods, one seed) on two daemons and checks the tables and runs.csv:
the transform part's online, model and offline rows, a latency row per
scenario of configs/lifelong, a false-alarm row per robot. The recall part
(the longest, about 3 minutes even quick) is left out. The build is
$YAMOR_BUILD, else the one $YAMORD lives in (build/release).
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO, YAMORD

from yamor.tools import lifelong_bench

BUILD = Path(os.environ.get("YAMOR_BUILD", YAMORD.parent.parent))
BENCH = [sys.executable, "-m", "yamor.tools.lifelong_bench"]


def load_bench():
    return lifelong_bench


def test_parse_args_defaults_quick_and_bad_values(capsys):
    bench = load_bench()
    args = bench.parse_args([])
    # The model budget is the runner's default (yamor-lifelong --model-budget).
    assert (args.online_budget, args.model_budget, args.offline_budget) == (45, 250, 1000)
    assert args.seed_list == [1, 2, 3, 4, 5] and args.short == []
    quick = bench.parse_args(["--quick", "--seeds", "4"])
    assert quick.seed_list == [1] and "--window-periods" in quick.short
    assert bench.parse_args(["--seed-list", "4,5"]).seed_list == [4, 5]
    for bad in (["--parts", "dance"], ["--robots", "octopus"], ["--seed-list", "0"], ["--daemons", "0"]):
        with pytest.raises(SystemExit):
            bench.parse_args(bad)
    err = capsys.readouterr().err
    assert "unknown part 'dance'" in err and "unknown robot 'octopus'" in err


def test_lifelong_bench_quick_writes_the_tables(tmp_path):
    for path in (BUILD / "host" / "yamord", BUILD / "optimizer-plugins" / "lifelong" / "yamor-lifelong",
                 BUILD / "optimizer-plugins" / "yamor-optimize", BUILD / "plugins" / "powell.so",
                 BUILD / "plugins" / "cmaes.so", BUILD / "tools" / "yamorctl" / "yamorctl"):
        if not path.exists():
            pytest.skip(f"not built: {path} (make build, or set YAMOR_BUILD)")
    bench = load_bench()
    result = subprocess.run([*BENCH, "--quick", "--parts", "transform,latency,false-alarm",
                             "--daemons", "2", "--quiet", "--build", str(BUILD), "--out", str(tmp_path)],
                            cwd=REPO, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    text = (tmp_path / "lifelong-bench.md").read_text()
    for heading in ("### 7.5.1 transformation", "### Detection latency", "### No false alarm"):
        assert heading in text
    with open(tmp_path / "runs.csv", newline="") as f:
        runs = list(csv.DictReader(f))
    by_part: dict[str, list[dict]] = {}
    for r in runs:
        by_part.setdefault(r["part"], []).append(r)
    # Transform: one online and one model life relearned within their quick
    # budgets (3 trials; 4 evaluations, 3 verified), both offline references ran.
    lives = {r["name"]: r for r in by_part["transform"]}
    assert set(lives) == {"online", "model"}
    assert int(lives["online"]["trials"]) == 3 and int(lives["online"]["evaluations"]) == 3
    assert int(lives["model"]["evaluations"]) <= 4 and int(lives["model"]["trials"]) <= 3
    for r in lives.values():
        assert float(r["velocity_after"]) >= 0 and float(r["robot_seconds"]) > 0
    assert {r["name"] for r in by_part["transform-offline"]} == {"powell", "cmaes"}
    # Latency: one row per scenario the part runs, each with its trigger.
    latency = {r["name"]: r for r in by_part["latency"]}
    assert set(latency) == set(bench.LATENCY_SCENARIOS)
    assert latency["transform"]["trigger"] == "module_disconnected"
    assert latency["limp_motor"]["trigger"] == "defect_set"
    assert latency["module_inserted"]["trigger"] == "module_connected"
    # False alarm: one life per robot of configs/robots.
    assert {r["name"] for r in by_part["false-alarm"]} == set(bench.ROBOTS)
    assert all(int(r["windows"]) > 0 for r in by_part["false-alarm"])
