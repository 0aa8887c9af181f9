"""End to end: yamor-optimize --hosts @FILE while daemons come and go (issue 17 §3).

A run starts on one yamord listed in a host file; mid-run a second daemon is
started and listed, the first unlisted and stopped, a third started and
listed, and the second SIGKILLed while listed; once the third has worked
alone the run is stopped (SIGINT), so no phase depends on how fast the
machine is. Every evaluation must be recorded once, in order, and equal the
same run's on a fixed pool with the budget it reached (the plugin's path
depends on every value, so a lost, repeated or misplaced evaluation would
show).
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import REPO, YAMORD
from test_optimize import OPTIMIZE
from test_resume import CONFIG

from yamor.launcher import start_daemon

ARGS = ["--plugin", "random", "--set", "batch=4",
        "--set", "shrink=0.8", "--seed", "11", "--config", str(CONFIG), "--world", "quadruped",
        "--warmup", "0.1", "--duration", "0.2", "--no-plot", "--quiet", "--log-level", "info"]


def _start_daemon(log: Path):
    """A one-worker daemon; its exit status is not checked (the test SIGKILLs one)."""
    return start_daemon(YAMORD, ["--workers", "1"], log=log, check=False)


def _rows(folder: Path):
    path = folder / "evaluations.csv"
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return [row for row in csv.DictReader(f) if row.get("wall_seconds")]


def _write_hosts(path: Path, addresses):
    temporary = path.with_suffix(".tmp")
    temporary.write_text("# yamord hosts\n" + "".join(f"{a}\n" for a in addresses))
    os.replace(temporary, path)  # atomically: the watcher never sees half a file


def _wait(condition, what, timeout=60.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    pytest.fail(f"timed out waiting for {what}")


def test_daemons_join_and_leave_through_the_host_file_without_loss(tmp_path):
    if not YAMORD.is_file() or not OPTIMIZE.is_file():
        pytest.skip("yamord or yamor-optimize not built")
    daemons = []
    try:
        a = _start_daemon(tmp_path / "a.log")
        daemons.append(a)
        hosts = tmp_path / "hosts.txt"
        _write_hosts(hosts, [a.address])
        out = tmp_path / "dynamic"
        log = open(tmp_path / "optimize.log", "w")
        run = subprocess.Popen([str(OPTIMIZE), *ARGS, "--set", "max_evaluations=100000",
                                "--hosts", f"@{hosts}", "--out", str(out)],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=log, text=True)
        _wait(lambda: len(_rows(out)) >= 4, "4 evaluations on a")

        b = _start_daemon(tmp_path / "b.log")
        daemons.append(b)
        _write_hosts(hosts, [a.address, b.address])
        _wait(lambda: any(r["host"] == b.address for r in _rows(out)), "an evaluation on b")

        _write_hosts(hosts, [b.address])
        done_on_b = sum(r["host"] == b.address for r in _rows(out))
        _wait(lambda: sum(r["host"] == b.address for r in _rows(out)) >= done_on_b + 2,
              "b going on alone")
        a.stop()  # unlisted, then stopped

        c = _start_daemon(tmp_path / "c.log")
        daemons.append(c)
        _write_hosts(hosts, [b.address, c.address])
        _wait(lambda: any(r["host"] == c.address for r in _rows(out)), "an evaluation on c")
        b.kill()  # dies while listed: its work is re-queued
        done_on_c = sum(r["host"] == c.address for r in _rows(out))
        _wait(lambda: sum(r["host"] == c.address for r in _rows(out)) >= done_on_c + 8,
              "c going on alone")

        run.send_signal(signal.SIGINT)  # stop; what was evaluated is kept
        stdout, _ = run.communicate(timeout=120)
        log.close()
        assert run.returncode == 130, stdout + (tmp_path / "optimize.log").read_text()
        reached = len(_rows(out))

        # The same run on a fixed pool (c alone), with the budget reached.
        reference = tmp_path / "reference"
        fixed = subprocess.run([str(OPTIMIZE), *ARGS, "--set", f"max_evaluations={reached}",
                                "--hosts", c.address, "--out", str(reference)],
                               cwd=REPO, capture_output=True, text=True, timeout=120)
        assert fixed.returncode == 0, fixed.stderr
    finally:
        for daemon in daemons:
            daemon.stop()

    rows = _rows(out)
    assert [int(r["index"]) for r in rows] == list(range(reached)), "each evaluation once, in order"
    assert {r["host"] for r in rows} == {a.address, b.address, c.address}

    def without_host_and_time(folder):
        return [{k: v for k, v in r.items() if k not in ("host", "wall_seconds")}
                for r in _rows(folder)]

    assert without_host_and_time(out) == without_host_and_time(reference)
    summaries = [json.loads((f / "summary.json").read_text()) for f in (out, reference)]
    assert summaries[0]["status"] == "stopped" and summaries[1]["status"] == "budget"
    for key in ("best", "evaluations", "parameters", "seed"):
        assert summaries[0][key] == summaries[1][key], key
    assert (out / "best.xml").read_text() == (reference / "best.xml").read_text()
    text = (tmp_path / "optimize.log").read_text()
    assert "drained and left the pool" in text or "down:" in text, text
