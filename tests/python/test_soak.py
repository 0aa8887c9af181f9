"""yamor-soak (yamor.tools.soak): its checks, a short soak of the release yamord, and that it fails when it must.

The long soak (64 clients, 10 min, the asan yamord) is run by hand with
`make soak`; these keep the tool from rotting.
"""

from __future__ import annotations

import json
import os
import re
import signal
import stat
import subprocess
import sys
import time

import pytest

from conftest import REPO, YAMORD
from yamor.v1 import host_pb2

from yamor.tools import soak, soak_client

SOAK = [sys.executable, "-m", "yamor.tools.soak"]


def needs_yamord():
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD} does not exist (make build, or set YAMORD)")


def test_clients_call_every_rpc():
    rpcs = {m.name for m in host_pb2.DESCRIPTOR.services_by_name["Host"].methods}
    assert soak_client.covered_rpcs() == rpcs, "add the new RPC to an action of soak_client.py"


def test_sanitizer_reports_are_recognised():
    log = "\n".join([
        "[2026-12-02 14:00:00.000] [warn] Sleep: refused, 64 calls in flight",
        "==123==ERROR: AddressSanitizer: heap-use-after-free on address 0x602000000010",
        "host/driver.cc:12:5: runtime error: signed integer overflow",
        "WARNING: ThreadSanitizer: data race (pid=9)",
        "==7==ERROR: LeakSanitizer: detected memory leaks",
        "plain line about an error",
    ])
    reports = soak.sanitizer_reports(log)
    assert len(reports) == 4 and "heap-use-after-free" in reports[0]
    assert soak.sanitizer_reports("[info] yamord stopped\nINVALID_ARGUMENT: runtime is 3") == []


def test_rss_growth_compares_medians_after_the_warm_up():
    # Cold start 10 MB, warm 100 MB (noisy), end 104 MB: +4 %, the cold value plays no part.
    samples = [(0.0, 10_000)] + [(t, 100_000 + (500 if t % 2 else -500)) for t in range(5, 15)]
    samples += [(t, 104_000) for t in range(15, 30)]
    warm, end, growth = soak.rss_growth(samples, warm_end=5, end=29, window=4)
    assert (warm, end) == (100_000, 104_000) and growth == pytest.approx(4.0)
    with pytest.raises(soak.SoakFailure):
        soak.rss_growth(samples, warm_end=100, end=120, window=5)


def test_a_too_short_duration_is_refused():
    with pytest.raises(SystemExit):
        soak.parse_args(["--duration", "5", "--warmup", "4", "--rss-window", "2"])
    with pytest.raises(SystemExit):
        soak.parse_args(["--clients", "10", "--processes", "4"])


def run_soak(*args: str, timeout: float = 240.0) -> subprocess.CompletedProcess:
    return subprocess.run([*SOAK, *args], capture_output=True, text=True, timeout=timeout,
                          cwd=REPO)


def test_short_soak_of_the_release_daemon_passes(tmp_path):
    needs_yamord()
    report = tmp_path / "soak.json"
    run = run_soak("--yamord", str(YAMORD), "--duration", "20", "--clients", "32",
                   "--processes", "4", "--kill-every", "3",
                   # 20 s is all ramp-up (threads, arenas): the RSS limit is for the long
                   # run; here it only catches a runaway.
                   "--max-rss-growth", "1000",
                   "--report", str(report))
    assert run.returncode == 0, run.stdout + run.stderr
    figures = json.loads(report.read_text())
    assert figures["calls"] > 100
    codes = figures["codes"]
    # Valid and invalid calls both reached the daemon, and streams were dropped.
    assert codes["OK"] > 0 and codes.get("INVALID_ARGUMENT", 0) > 0
    assert codes.get("NOT_FOUND", 0) + codes.get("OUT_OF_RANGE", 0) > 0
    assert figures["per_rpc"]["WatchState"].get("DROPPED", 0) > 0
    assert figures["per_rpc"]["Evaluate"].get("OK", 0) > 0
    assert figures["client_processes_killed"] >= 3
    assert not set(codes) & set(soak.BAD_CODES)
    rss = figures["rss_kb"]
    assert 0 < rss["cold"] <= rss["peak"] and rss["warm"] > 0 and rss["end"] > 0
    assert "soak passed" in run.stdout


def test_soak_fails_when_the_daemon_dies():
    needs_yamord()
    proc = subprocess.Popen([*SOAK, "--yamord", str(YAMORD), "--duration", "60", "--clients",
                             "4", "--processes", "2"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=REPO)
    try:
        first = proc.stdout.readline()
        match = re.search(r"yamord pid (\d+)", first)
        assert match, first + proc.stderr.read()
        time.sleep(3)
        os.kill(int(match.group(1)), signal.SIGSEGV)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 1
    assert "soak FAILED: yamord died" in err and "SIGSEGV" in err, err


def test_soak_fails_on_a_sanitizer_report(tmp_path):
    needs_yamord()
    # A daemon that serves, and writes a report to its stderr after 3 s.
    wrapper = tmp_path / "yamord-reporting"
    wrapper.write_text("#!/bin/sh\n"
                       "( sleep 3; echo '==1==ERROR: AddressSanitizer: heap-use-after-free on"
                       " address 0x602000000010' >&2 ) &\n"
                       f"exec '{YAMORD}' \"$@\"\n")
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IXUSR)
    run = run_soak("--yamord", str(wrapper), "--duration", "60", "--clients", "4",
                   "--processes", "2", timeout=120)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "sanitizer report" in run.stderr and "heap-use-after-free" in run.stderr, run.stderr
