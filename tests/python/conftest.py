"""Fixtures: one real yamord for the whole session, a yamor.Host on it, yamorctl.

The daemon is build/release/host/yamord (what `make test` builds) unless the
YAMORD environment variable names another; yamorctl likewise
build/release/tools/yamorctl/yamorctl or YAMORCTL. Tests that need a binary
are skipped, with the path in the reason, only when it does not exist.
"""

from __future__ import annotations

import os
import select
import subprocess
from pathlib import Path

import pytest

import yamor
from yamor.launcher import start_daemon

REPO = Path(__file__).resolve().parents[2]
# The package under test is this checkout's (`make deps` installs it editable
# into .venv; another worktree sets PYTHONPATH=tools/python), also in the
# tools the tests start as subprocesses.
if not Path(yamor.__file__).resolve().is_relative_to(REPO / "tools" / "python"):
    raise ImportError(f"yamor is imported from {yamor.__file__}, not from {REPO / 'tools' / 'python'}: "
                      "run `make deps`, or set PYTHONPATH=tools/python")
YAMORD = Path(os.environ.get("YAMORD", REPO / "build" / "release" / "host" / "yamord"))
YAMORCTL = Path(os.environ.get("YAMORCTL",
                               REPO / "build" / "release" / "tools" / "yamorctl" / "yamorctl"))
START_TIMEOUT = 60.0


def _read_line(stream, timeout: float) -> str:
    """One line of `stream`, or "" at EOF / after `timeout` seconds (for the other programs' banners)."""
    ready, _, _ = select.select([stream], [], [], timeout)
    return stream.readline() if ready else ""


@pytest.fixture(scope="session")
def yamord(tmp_path_factory):
    """Address "127.0.0.1:PORT" of a yamord started for this session.

    Stopped with SIGTERM at the end; it must exit 0 (drained cleanly).
    """
    if not YAMORD.is_file():
        pytest.skip(f"yamord not built: {YAMORD} does not exist (make build, or set YAMORD)")
    log = tmp_path_factory.mktemp("yamord") / "yamord.log"
    daemon = start_daemon(YAMORD, log=log, timeout=START_TIMEOUT, check=False)
    try:
        yield daemon.address
    finally:
        code = daemon.stop()
    assert code == 0, f"yamord exit status {code} after SIGTERM; log:\n{log.read_text()}"


@pytest.fixture(scope="session")
def host(yamord):
    """A yamor.Host on the session's daemon (10 s deadlines)."""
    with yamor.Host(yamord, timeout=10.0) as h:
        h.wait_ready(timeout=START_TIMEOUT)
        yield h


@pytest.fixture
def fresh(host):
    """The host with the default world (quadruped, built-in configuration) freshly opened."""
    host.set_free_run(0)
    host.open_simulation(world="quadruped", seed=1)
    return host


@pytest.fixture(scope="session")
def yamorctl(yamord):
    """run(*args) -> CompletedProcess of yamorctl against the session's daemon."""
    if not YAMORCTL.is_file():
        pytest.skip(f"yamorctl not built: {YAMORCTL} does not exist (make build, or set YAMORCTL)")

    def run(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
        return subprocess.run([str(YAMORCTL), "--host", yamord, *args], capture_output=True,
                              text=True, timeout=timeout, cwd=REPO)

    return run

