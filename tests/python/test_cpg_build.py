"""End to end: yamor-cpg-build turns a morphology into a problem yamor-optimize runs.

Runs the real binary on built-in worlds and on the session daemon's robot as
it is now (before and after the thesis 7.5.1 transformation), loads its output
with yamor-optimize against that daemon, and checks that bad input exits 2
naming what was wrong.
"""

from __future__ import annotations

import csv
import os
import re
import subprocess
from pathlib import Path

import pytest

from conftest import REPO

BUILD = Path(os.environ.get("YAMOR_CPG_BUILD",
                            REPO / "build" / "release" / "tools" / "cpg_build" / "yamor-cpg-build"))
OPTIMIZE = Path(os.environ.get("YAMOR_OPTIMIZE",
                               REPO / "build" / "release" / "optimizer-plugins" / "yamor-optimize"))
WORLDS = ["quadruped", "snake", "tripod", "dog", "trebuchet", "wheel"]
OPTIMIZE_LINE = re.compile(r'<optimize param="([^"]+)"')


def run_build(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    if not BUILD.is_file():
        pytest.skip(f"yamor-cpg-build not built: {BUILD}")
    result = subprocess.run([str(BUILD), *args], cwd=REPO, capture_output=True, text=True, timeout=120)
    if check:
        assert result.returncode == 0, result.stderr
    return result


@pytest.mark.parametrize("world", WORLDS)
def test_every_world_gets_a_problem_within_the_budget(world, tmp_path):
    out = tmp_path / f"{world}.xml"
    run_build("--world", world, "-o", str(out))
    free = OPTIMIZE_LINE.findall(out.read_text())
    assert 1 <= len(free) <= 7, free
    explain = run_build("--world", world, "--explain").stdout
    assert "orbits:" in explain and "free parameters:" in explain


def test_the_key_names_the_body_not_the_ids():
    quadruped = run_build("--world", "quadruped", "--key").stdout.strip()
    assert re.fullmatch(r"[0-9a-f]{16}", quadruped)
    assert run_build("--world", "quadruped", "--key").stdout.strip() == quadruped
    assert run_build("--world", "tripod", "--key").stdout.strip() != quadruped


def test_the_generated_problem_runs_with_yamor_optimize(yamord, tmp_path):
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    problem = tmp_path / "quadruped-auto.xml"
    run_build("--world", "quadruped", "-o", str(problem))
    out = tmp_path / "run"
    result = subprocess.run(
        [str(OPTIMIZE), "--log-level", "warn", "--quiet", "--plugin", "random", "--config", str(problem),
         "--hosts", yamord, "--world", "quadruped", "--warmup", "1", "--duration", "1",
         "--set", "max_evaluations=4", "--seed", "2", "--out", str(out)],
        cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    with open(out / "evaluations.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    assert set(OPTIMIZE_LINE.findall(problem.read_text())) <= set(rows[0].keys())


def test_the_daemons_robot_as_it_is_now(host, yamord):
    host.open_simulation("quadruped")
    try:
        before = run_build("--daemon", yamord, "--key").stdout.strip()
        assert before == run_build("--world", "quadruped", "--key").stdout.strip()
        host.run_script_file(REPO / "configs" / "scripts" / "quadruped-transform.xml")
        after = run_build("--daemon", yamord, "--key").stdout.strip()
        assert after != before, "GetMorphology still reports the body before the transformation"
        explain = run_build("--daemon", yamord, "--explain").stdout
        assert "free parameters:" in explain
    finally:
        host.open_simulation("quadruped")  # the session daemon's default world again, for later tests


@pytest.mark.parametrize("args, message", [
    (["--world", "nosuch"], "nosuch"),
    (["--world", "quadruped", "--keep-free", "0-2"], "keep-free coupling 0-2"),
    (["--world", "quadruped", "--keep-free", "0-1", "--keep-free", "1-2", "--keep-free", "2-3",
      "--keep-free", "0-3"], "close a loop"),
    (["--world", "quadruped", "--passive", "0,1,2,3,5,6,7,8"], "no driven module"),
    (["--world", "quadruped", "--passive", "77"], "module 77"),
    (["--morphology", "/nonexistent/m.xml"], "/nonexistent/m.xml"),
    (["--daemon", "127.0.0.1:1", "--timeout", "1"], "127.0.0.1:1"),
])
def test_bad_input_exits_2_naming_it(args, message):
    result = run_build(*args, check=False)
    assert result.returncode == 2, result.stdout + result.stderr
    assert message in result.stderr
