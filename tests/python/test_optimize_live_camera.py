"""End to end, the real-robot path (issue 15 §3): yamor-optimize --live learns
online on a robot whose position comes from the ceiling camera.

yamor-bridge on TCP stands in for the real robot, behind
`yamord --backend serial`; yamor-camapp films it and yamord's LED tracker
turns the camera's pixels into metres (`--position-source tracker`: the bridge
answers its position specials, but RobotPosition reports what the camera
sees). The random plugin runs a few short trials of configs/optimize/
quadruped-2.xml. Then the camera is killed: the next live run fails naming the
tracker instead of measuring stale positions.
"""

from __future__ import annotations

import csv
import json
import contextlib
import os
import signal
import subprocess
from pathlib import Path

import pytest

from conftest import REPO, START_TIMEOUT, YAMORD, _read_line
from test_optimize import OPTIMIZE, _free_port, read_csv, run_optimize

import yamor
from yamor.launcher import start_daemon

BUILD = REPO / "build" / "release"
CAMAPP = Path(os.environ.get("YAMOR_CAMAPP", BUILD / "tools" / "camapp" / "yamor-camapp"))
BRIDGE = Path(os.environ.get("YAMOR_BRIDGE", BUILD / "bridge" / "yamor-bridge"))
CONFIG = REPO / "configs" / "optimize" / "quadruped-2.xml"
PERIOD = 1 / 0.3
LED_HEIGHT = "0.0401"  # the quadruped's central module at rest


def _start(args, log: Path):
    with open(log, "w") as stderr:
        return subprocess.Popen([str(a) for a in args], stdout=subprocess.PIPE, stderr=stderr,
                                text=True, cwd=REPO)


def _stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    proc.stdout.close()


@pytest.fixture
def rig(tmp_path):
    """yamor-bridge (TCP) <- yamord --backend serial + tracker <- yamor-camapp."""
    for binary in (YAMORD, OPTIMIZE, CAMAPP, BRIDGE):
        if not binary.is_file():
            pytest.skip(f"not built: {binary}")
    calibration = tmp_path / "camera.txt"
    subprocess.run([str(CAMAPP), "--calibration-only", "--write-calibration", str(calibration),
                    "--led-height", LED_HEIGHT], check=True, capture_output=True, timeout=60)
    with contextlib.ExitStack() as stack:  # stops camera, daemon, bridge
        bridge = _start([BRIDGE, "--tcp", "127.0.0.1:0", "--log-level", "warn"], tmp_path / "bridge.log")
        stack.callback(_stop, bridge)
        line = _read_line(bridge.stdout, START_TIMEOUT).strip()
        assert line.startswith("yamor-bridge: tcp 127.0.0.1:"), line
        camera_port = _free_port()
        daemon = stack.enter_context(start_daemon(
            YAMORD, ["--log-level", "warn", "--backend", "serial", "--device", "tcp://" + line.split()[-1],
                     "--led-tracker", f"127.0.0.1:{camera_port}", "--tracker-calibration", calibration,
                     "--position-source", "tracker", "--tracker-max-age", "2"],
            log=tmp_path / "yamord.log", timeout=START_TIMEOUT))
        address = daemon.address
        truth = tmp_path / "truth.csv"
        camera = _start([CAMAPP, "--yamord", address, "--listen", f"127.0.0.1:{camera_port}",
                         "--latency", "0.01", "--truth", truth, "--log-level", "warn"],
                        tmp_path / "camapp.log")
        stack.callback(_stop, camera)
        assert _read_line(camera.stdout, START_TIMEOUT).strip() == \
            f"yamor-camapp: listening on 127.0.0.1:{camera_port}"
        yield {"address": address, "camera": camera, "truth": truth}


def test_live_optimization_measures_with_the_camera(rig, tmp_path):
    daemon = rig["address"]
    out = tmp_path / "run"
    result = run_optimize(["--plugin", "random", "--config", str(CONFIG), "--live", daemon,
                           "--live-settle-periods", "0.5", "--live-measure-periods", "1",
                           "--set", "max_evaluations=3", "--no-plot", "--out", str(out)], timeout=300)
    assert f"live robot {daemon} (tcp, virtual time" in result.stderr, result.stderr  # the bridge on TCP
    summary = json.loads((out / "summary.json").read_text())
    assert summary["live"] is True and summary["status"] == "budget"
    assert summary["evaluations"] == 3
    rows = read_csv(out / "evaluations.csv")
    assert len(rows) == 3
    for row in rows:
        assert float(row["robot_seconds"]) == pytest.approx(1.5 * PERIOD, abs=0.2)
        assert float(row["velocity"]) == pytest.approx(float(row["distance"]) / PERIOD, rel=0.02)
    assert len({row["velocity"] for row in rows}) > 1, "the candidates differ"

    with yamor.Host(daemon, timeout=10.0) as host:
        tracked = host.position()
        truth = host.simulated_position()
        assert tracked.source == "led-tracker"
        assert tracked.time == pytest.approx(truth.time, abs=1e-6)
        assert ((tracked.x - truth.x) ** 2 + (tracked.y - truth.y) ** 2) ** 0.5 < 0.005
    with open(rig["truth"], newline="") as f:
        frames = list(csv.DictReader(f))
    assert len(frames) > 3 * 1.5 * PERIOD * 5, "filmed throughout the trials"
    assert max(float(f["sim_time"]) for f in frames) >= 3 * 1.5 * PERIOD

    # Without the camera the robot has no position: the run fails, naming the tracker.
    rig["camera"].kill()
    rig["camera"].wait()
    failed = run_optimize(["--plugin", "random", "--config", str(CONFIG), "--live", daemon,
                           "--live-settle-periods", "0", "--live-measure-periods", "0.5",
                           "--set", "max_evaluations=1", "--no-plot", "--out", str(tmp_path / "dead")],
                          timeout=120, check=False)
    assert failed.returncode != 0, failed.stdout + failed.stderr
    assert "led-tracker" in failed.stderr, failed.stderr
