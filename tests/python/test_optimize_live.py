"""End to end: yamor-optimize --live on the robot of one real yamord.

Each test starts its own daemon (the simulated quadruped, not connected) on
an ephemeral port and runs the real yamor-optimize binary with the random
plugin on configs/optimize/quadruped-2.xml (0.3 Hz: a CPG period of 10/3 s)
with short trials (half a period of settling, one measured period: 5 s of
robot time each). Checks the robot was prepared (configuration loaded,
connected), the results folder records the live run and its robot time, the
flag errors, a dead daemon, and stopping with SIGINT.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time

import pytest

from conftest import REPO, YAMORD
from test_optimize import OPTIMIZE, _free_port, read_csv, run_optimize

import yamor
from yamor.launcher import start_daemon

CONFIG = REPO / "configs" / "optimize" / "quadruped-2.xml"
SHORT = ["--live-settle-periods", "0.5", "--live-measure-periods", "1"]
PERIOD = 1 / 0.3


@pytest.fixture
def daemon(tmp_path):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD}")
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    with start_daemon(YAMORD, ["--workers", "1"], log=tmp_path / "yamord.log") as daemon:
        yield daemon.address


def test_random_learns_live_and_records_the_robot_time(daemon, tmp_path):
    out = tmp_path / "run"
    with yamor.Host(daemon, timeout=10.0) as host:
        assert not host.info().connected
        result = run_optimize(["--plugin", "random", "--config", str(CONFIG), "--live", daemon,
                               *SHORT, "--set", "max_evaluations=5", "--no-plot",
                               "--out", str(out)], timeout=120)
        assert "robot time:" in result.stdout
        # The optimization configuration's robot was loaded and connected
        # (quadruped-2's hips differ from the built-in 0.78).
        assert host.info().connected
        assert host.amplitude(0) == pytest.approx(0.3345214399655798)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["live"] is True
    assert summary["evaluator"] == f"live {daemon}"
    assert summary["status"] == "budget"
    assert summary["evaluations"] == 5
    assert summary["robot_seconds"] == pytest.approx(5 * 1.5 * PERIOD, abs=0.5)
    rows = read_csv(out / "evaluations.csv")
    assert len(rows) == 5
    for row in rows:
        assert row["host"] == daemon
        assert float(row["robot_seconds"]) == pytest.approx(1.5 * PERIOD, abs=0.1)
        assert float(row["velocity"]) == pytest.approx(float(row["distance"]) / PERIOD, rel=0.01)
    assert len({row["velocity"] for row in rows}) > 1, "the candidates differ"
    assert (out / "best.xml").exists()


@pytest.mark.parametrize("args, message", [
    (["--live", "127.0.0.1:1", "--hosts", "127.0.0.1:2"], "--hosts cannot be combined with --live"),
    (["--live", "127.0.0.1:1", "--world", "snake"], "--world cannot be combined with --live"),
    (["--live", "127.0.0.1:1", "--warmup", "2"], "--warmup cannot be combined with --live"),
    (["--live", "127.0.0.1:1,127.0.0.1:2"], "--live takes one HOST:PORT"),
    (["--live-measure-periods", "2"], "--live-measure-periods needs --live"),
])
def test_bad_live_arguments_exit_2_naming_the_problem(tmp_path, args, message):
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    result = run_optimize(["--plugin", "random", "--config", str(CONFIG), *args,
                           "--out", str(tmp_path / "out")], timeout=60, check=False)
    assert result.returncode == 2, result.stdout + result.stderr
    assert message in result.stderr


def test_an_unreachable_live_daemon_fails_clearly(tmp_path):
    if not OPTIMIZE.is_file():
        pytest.skip(f"yamor-optimize not built: {OPTIMIZE}")
    address = f"127.0.0.1:{_free_port()}"
    result = run_optimize(["--plugin", "random", "--config", str(CONFIG), "--live", address,
                           "--out", str(tmp_path / "out")], timeout=60, check=False)
    assert result.returncode == 1, result.stdout + result.stderr
    assert address in result.stderr


def test_sigint_stops_a_live_trial_and_keeps_the_results(daemon, tmp_path):
    out = tmp_path / "run"
    proc = subprocess.Popen([str(OPTIMIZE), "--log-level", "warn", "--quiet", "--plugin", "random",
                             "--config", str(CONFIG), "--live", daemon, "--live-settle-periods", "0",
                             "--live-measure-periods", "0.5", "--no-plot", "--out", str(out)],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    csv_path = out / "evaluations.csv"
    while time.monotonic() < deadline:
        if csv_path.exists() and len(csv_path.read_text().splitlines()) >= 3:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped"
    assert summary["live"] is True
    assert summary["evaluations"] == len(read_csv(csv_path)) >= 2
