"""End to end: yamor-optimize --resume after SIGKILL (issue 17 §2).

Two real yamord (one Evaluate worker each) on ephemeral ports; short
evaluations (0.1 s warm-up + 0.2 s) and tiny budgets keep each case a few
seconds. Each case SIGKILLs a run at a seeded random moment (sometimes the
resumed run too), resumes it, and compares the folder with an uninterrupted
run of the same arguments: summary.json without its timing fields, best.xml,
and evaluations.csv without the host and wall_seconds columns are identical;
rows recorded before the kill are kept byte for byte.
"""

from __future__ import annotations

import json
import random
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import REPO, YAMORD
from test_optimize import OPTIMIZE

from yamor.launcher import start_daemons

CONFIG = REPO / "configs" / "optimize" / "quadruped-2.xml"
SHORT = ["--world", "quadruped", "--warmup", "0.1", "--duration", "0.2", "--no-plot", "--quiet",
         "--log-level", "warn"]
# Two plugins: random search whose box shrinks around the best so far (its
# path depends on every value), and Powell's sequential line searches.
SCENARIOS = {
    "random": ["--plugin", "random", "--set", "max_evaluations=13", "--set", "batch=4",
               "--set", "shrink=0.6", "--seed", "3"],
    "powell": ["--plugin", "powell", "--set", "max_evaluations=12", "--seed", "4"],
}
CASES = 10
TIMING = ("wall_seconds", "evaluations_per_second")


@pytest.fixture(scope="module")
def hosts(tmp_path_factory):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD}")
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    with start_daemons(2, YAMORD, ["--workers", "1"],
                       log_dir=tmp_path_factory.mktemp("daemons")) as daemons:
        yield daemons.hosts_arg()


def _command(hosts, scenario, *extra, replace=None):
    """The command of `scenario`; `replace` maps an option to another value."""
    args = [str(OPTIMIZE), "--config", str(CONFIG), "--hosts", hosts, *SHORT,
            *SCENARIOS[scenario], *extra]
    for option, value in (replace or {}).items():
        args[args.index(option) + 1] = value
    return args


def _run(args, timeout=120):
    return subprocess.run(args, cwd=REPO, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def references(hosts, tmp_path_factory):
    """Per scenario: the uninterrupted run's folder and how long it took."""
    out = {}
    for scenario in SCENARIOS:
        folder = tmp_path_factory.mktemp("reference") / scenario
        start = time.monotonic()
        result = _run(_command(hosts, scenario, "--out", str(folder)))
        assert result.returncode == 0, result.stderr
        out[scenario] = (folder, time.monotonic() - start)
    return out


def _summary(folder: Path):
    summary = json.loads((folder / "summary.json").read_text())
    for key in TIMING:
        summary.pop(key)
    return summary


def _csv_without_host_and_time(folder: Path):
    # Which daemon ran an evaluation, and how long it took, depend on timing.
    rows = (folder / "evaluations.csv").read_text().splitlines()
    return [",".join(row.split(",")[:-2]) for row in rows]


def _kill_after(args, delay: float) -> bool:
    """Runs `args`, SIGKILLs it after `delay` s; False if it ended first."""
    proc = subprocess.Popen(args, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        proc.wait(timeout=delay)
        return False
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        return True


@pytest.mark.parametrize("case", range(CASES))
def test_a_killed_run_resumes_to_the_uninterrupted_result(hosts, references, tmp_path, case):
    scenario = list(SCENARIOS)[case % len(SCENARIOS)]
    reference, duration = references[scenario]
    rng = random.Random(1000 + case)  # seeded: the same kill moments every time
    folder = tmp_path / "run"
    killed = _kill_after(_command(hosts, scenario, "--out", str(folder)),
                         rng.uniform(0.05, 0.8 * duration))
    if not folder.exists():
        pytest.skip("killed before the results folder existed: nothing to resume")
    before = (folder / "evaluations.csv").read_bytes() if (folder / "evaluations.csv").exists() \
        else b""
    recorded = before.count(b"\n")
    print(f"case {case} {scenario}: killed={killed}, {recorded} lines recorded")
    resume = _command(hosts, scenario, "--resume", str(folder))
    if case % 3 == 2:  # kill the resumed run too, then resume again
        _kill_after(resume, rng.uniform(0.05, duration / 2))
    result = _run(resume)
    assert result.returncode == 0, f"killed={killed}\n{result.stdout}\n{result.stderr}"

    assert _summary(folder) == _summary(reference)
    assert (folder / "best.xml").read_text() == (reference / "best.xml").read_text()
    assert _csv_without_host_and_time(folder) == _csv_without_host_and_time(reference)
    # What was recorded before the kill stays as it was (a torn last line
    # excepted: it is dropped and evaluated again).
    kept = before[:before.rfind(b"\n") + 1]
    assert (folder / "evaluations.csv").read_bytes().startswith(kept)


def test_resume_refuses_another_seed_or_budget_naming_the_difference(hosts, references, tmp_path):
    reference, _ = references["random"]
    folder = tmp_path / "copy"
    folder.mkdir()
    for name in ("run.toml", "evaluations.csv"):
        (folder / name).write_bytes((reference / name).read_bytes())
    result = _run(_command(hosts, "random", "--resume", str(folder), replace={"--seed": "9"}))
    assert result.returncode != 0
    assert "seed: recorded '3', now '9'" in result.stderr, result.stderr
    assert "it was started as: " in result.stderr
    result = _run(_command(hosts, "random", "--resume", str(folder), replace={"--duration": "0.3"}))
    assert result.returncode != 0
    assert "evaluation: recorded 'world=quadruped morphology=none warmup=0.1 duration=0.2" \
        in result.stderr, result.stderr
    result = _run(_command(hosts, "powell", "--resume", str(folder)))
    assert result.returncode != 0
    assert "plugin: recorded 'random" in result.stderr, result.stderr
    assert (folder / "evaluations.csv").read_bytes() == (reference / "evaluations.csv").read_bytes()


def test_resume_of_a_missing_folder_exits_2(hosts, tmp_path):
    result = _run(_command(hosts, "random", "--resume", str(tmp_path / "nothing")))
    assert result.returncode == 2
    assert "no such results folder" in result.stderr
