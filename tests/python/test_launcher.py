"""yamor.launcher: daemons start serving, stop with exit status 0, and never outlive
the process that started them (a `with` block, an exception, Ctrl-C, an exit that
forgot them, a SIGKILLed parent)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

import yamor
from conftest import YAMORD
from yamor.launcher import LaunchError, start_daemon, start_daemons

pytestmark = pytest.mark.skipif(not YAMORD.is_file(), reason=f"yamord not built: {YAMORD}")


def gone(pid: int, timeout: float = 30.0) -> bool:
    """True once process `pid` no longer exists (or is a zombie), within `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                    return True
        except FileNotFoundError:
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)


def child(code: str, *args: str) -> subprocess.Popen:
    """A Python process running `code` (which prints the daemons' pids, one line, when they serve)."""
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), str(YAMORD), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_two_daemons_serve_on_their_own_ports_and_exit_zero(tmp_path):
    with start_daemons(2, YAMORD, ["--workers", "1"], log_dir=tmp_path) as daemons:
        assert len(set(daemons.addresses)) == 2
        assert daemons.hosts_arg() == ",".join(daemons.addresses)
        for daemon in daemons:
            with yamor.Host(daemon.address, timeout=10.0) as host:
                assert host.info().version
        pids = [d.pid for d in daemons]
    assert [d.returncode for d in daemons] == [0, 0]
    assert all(gone(pid, 0.0) for pid in pids)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["yamord1.log", "yamord2.log"]


def test_a_daemon_that_cannot_start_names_its_error_and_is_reaped(tmp_path):
    with pytest.raises(LaunchError, match="did not report its port(.|\n)*--no-such-option"):
        start_daemon(YAMORD, ["--no-such-option"], log=tmp_path / "yamord.log")


def test_a_missing_binary_is_named(tmp_path):
    with pytest.raises(LaunchError, match=f"{tmp_path / 'yamord'} does not exist"):
        start_daemons(1, tmp_path / "yamord")


def test_stop_checks_the_exit_status(tmp_path):
    daemon = start_daemon(YAMORD, log=tmp_path / "yamord.log")
    assert daemon.kill() == -signal.SIGKILL
    with pytest.raises(LaunchError, match="killed by SIGKILL after SIGTERM"):
        daemon.stop()
    assert daemon.stop(check=False) == -signal.SIGKILL


def test_an_exception_in_the_block_stops_the_daemons_and_is_not_masked(tmp_path):
    with pytest.raises(RuntimeError, match="the test's own"):
        with start_daemons(2, YAMORD, log_dir=tmp_path) as daemons:
            daemons[0].kill()  # a bad exit status would raise too, but the exception wins
            pids = [d.pid for d in daemons]
            raise RuntimeError("the test's own")
    assert all(gone(pid, 0.0) for pid in pids)


@pytest.mark.parametrize("ending", ["exit without stopping", "ctrl-c", "sigkill"])
def test_no_daemon_outlives_its_parent(ending, tmp_path):
    proc = child("""
        import sys, time
        from yamor.launcher import start_daemons
        daemons = start_daemons(2, sys.argv[1], log_dir=sys.argv[3])
        print(" ".join(str(d.pid) for d in daemons), flush=True)
        if sys.argv[2] == "exit without stopping":
            sys.exit(0)
        with daemons:
            time.sleep(600)
    """, ending, str(tmp_path))
    try:
        pids = [int(p) for p in proc.stdout.readline().split()]
        assert len(pids) == 2, proc.stderr.read()
        if ending == "ctrl-c":
            proc.send_signal(signal.SIGINT)  # the daemons, in their own session, do not get it
        elif ending == "sigkill":
            proc.kill()  # no clean-up in the parent: the kernel tells the daemons
        proc.wait(timeout=60)
        for pid in pids:
            assert gone(pid), f"yamord {pid} outlived its parent ({ending})"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        proc.stderr.close()
