"""SIGTERM during a long virtual-time Sleep: the daemon drains cleanly.

The caller of the in-flight Sleep gets UNAVAILABLE ("yamord is shutting
down") promptly, not a hang until its deadline, and yamord exits 0.
"""
import threading
import time

import pytest

import yamor
from conftest import YAMORD
from yamor.launcher import start_daemon


def test_sigterm_during_long_sleep_answers_unavailable_and_exits_zero(tmp_path):
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD} does not exist")
    log = tmp_path / "yamord.log"
    with start_daemon(YAMORD, log=log) as daemon:
        with yamor.Host(daemon.address, timeout=30.0) as host:
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
            assert daemon.stop(timeout=10, check=False) == 0, log.read_text()
            thread.join(timeout=30)
            assert not thread.is_alive()
            error = outcome["error"]
            assert error is not None and error.code == "UNAVAILABLE", error
            assert "shutting down" in error.message
            assert outcome["at"] - signalled < 5.0, "the Sleep's caller waited for its deadline"
