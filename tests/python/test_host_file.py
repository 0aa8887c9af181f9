"""End to end: yamor-optimize --hosts @FILE while daemons come and go (issue 17 §3).

A run starts on one yamord listed in a host file; mid-run a second daemon is
started and listed, the first unlisted and stopped, a third started and
listed, and the second SIGKILLed while listed. The run must end with every
evaluation recorded once, in order, and with the same evaluations and result
as the same run on a fixed pool (the plugin's path depends on every value, so
a lost, repeated or misplaced evaluation would show).
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
from test_resume import CONFIG, _start_daemon

ARGS = ["--plugin", "random", "--set", "max_evaluations=40", "--set", "batch=4",
        "--set", "shrink=0.8", "--seed", "11", "--config", str(CONFIG), "--world", "quadruped",
        "--warmup", "0.1", "--duration", "0.2", "--no-plot", "--quiet", "--log-level", "info"]


def _stop(proc, sig=signal.SIGTERM):
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    proc.stdout.close()


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
        _write_hosts(hosts, [a[1]])
        out = tmp_path / "dynamic"
        log = open(tmp_path / "optimize.log", "w")
        run = subprocess.Popen([str(OPTIMIZE), *ARGS, "--hosts", f"@{hosts}", "--out", str(out)],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=log, text=True)
        _wait(lambda: len(_rows(out)) >= 4, "4 evaluations on a")

        b = _start_daemon(tmp_path / "b.log")
        daemons.append(b)
        _write_hosts(hosts, [a[1], b[1]])
        _wait(lambda: any(r["host"] == b[1] for r in _rows(out)), "an evaluation on b")

        _write_hosts(hosts, [b[1]])
        done_on_b = sum(r["host"] == b[1] for r in _rows(out))
        _wait(lambda: sum(r["host"] == b[1] for r in _rows(out)) >= done_on_b + 2,
              "b going on alone")
        _stop(a[0])  # unlisted, then stopped

        c = _start_daemon(tmp_path / "c.log")
        daemons.append(c)
        _write_hosts(hosts, [b[1], c[1]])
        _wait(lambda: any(r["host"] == c[1] for r in _rows(out)), "an evaluation on c")
        b[0].send_signal(signal.SIGKILL)  # dies while listed: its work is re-queued

        stdout, _ = run.communicate(timeout=120)
        log.close()
        assert run.returncode == 0, stdout + (tmp_path / "optimize.log").read_text()

        # The same run on a fixed pool (c alone) for comparison.
        reference = tmp_path / "reference"
        fixed = subprocess.run([str(OPTIMIZE), *ARGS, "--hosts", c[1], "--out", str(reference)],
                               cwd=REPO, capture_output=True, text=True, timeout=120)
        assert fixed.returncode == 0, fixed.stderr
    finally:
        for proc, _ in daemons:
            _stop(proc)

    rows = _rows(out)
    assert [int(r["index"]) for r in rows] == list(range(40)), "each evaluation once, in order"
    assert {r["host"] for r in rows} == {a[1], b[1], c[1]}

    def without_host_and_time(folder):
        return [{k: v for k, v in r.items() if k not in ("host", "wall_seconds")}
                for r in _rows(folder)]

    assert without_host_and_time(out) == without_host_and_time(reference)
    summaries = [json.loads((f / "summary.json").read_text()) for f in (out, reference)]
    for s in summaries:
        for key in ("wall_seconds", "evaluations_per_second", "evaluator"):
            s.pop(key)
    assert summaries[0] == summaries[1]
    assert summaries[0]["status"] == "budget"
    assert (out / "best.xml").read_text() == (reference / "best.xml").read_text()
    text = (tmp_path / "optimize.log").read_text()
    assert "drained and left the pool" in text or "down:" in text, text
