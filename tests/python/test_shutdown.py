"""SIGTERM during a long virtual-time Sleep: the daemon drains cleanly.

The caller of the in-flight Sleep gets UNAVAILABLE ("yamord is shutting
down") promptly, not a hang until its deadline, and yamord exits 0.
"""
import signal
import subprocess
import threading
import time

import pytest

import yamor
from conftest import LISTENING, REPO, START_TIMEOUT, YAMORD, _read_line


def test_sigterm_during_long_sleep_answers_unavailable_and_exits_zero(tmp_path):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD} does not exist")
    log = tmp_path / "yamord.log"
    with open(log, "w") as stderr:
        proc = subprocess.Popen([str(YAMORD), "--listen", "127.0.0.1:0"], stdout=subprocess.PIPE,
                                stderr=stderr, text=True, cwd=REPO)
    try:
        match = LISTENING.match(_read_line(proc.stdout, START_TIMEOUT).strip())
        assert match, log.read_text()
        with yamor.Host(f"{match.group(1)}:{match.group(2)}", timeout=30.0) as host:
            host.connect()
            outcome = {}

            def sleeper():
                try:
                    host.sleep(80000.0, timeout=30.0)  # far longer than the test
                    outcome["error"] = None
                except yamor.HostError as e:
                    outcome["error"] = e
                outcome["at"] = time.monotonic()

            thread = threading.Thread(target=sleeper)
            thread.start()
            deadline = time.monotonic() + 20
            while host.elapsed_time() < 0.5 and time.monotonic() < deadline:
                time.sleep(0.01)
            assert host.elapsed_time() >= 0.5, "the Sleep never started stepping"
            signalled = time.monotonic()
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=10) == 0, log.read_text()
            thread.join(timeout=30)
            assert not thread.is_alive()
            error = outcome["error"]
            assert error is not None and error.code == "UNAVAILABLE", error
            assert "shutting down" in error.message
            assert outcome["at"] - signalled < 5.0, "the Sleep's caller waited for its deadline"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
