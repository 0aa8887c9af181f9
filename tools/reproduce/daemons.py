"""A local pool of yamord daemons and yamor-optimize runs that stop cleanly.

Shared by tools/reproduce/reproduce.py and tools/bench/learning_bench.py.

    with DaemonPool.start(yamord, count=2, log_dir=out) as pool:
        run_optimize(optimize, [..., "--hosts", pool.hosts_arg()])

`DaemonPool.start` launches `count` daemons (`--listen 127.0.0.1:0
--workers 1`) and reads the "yamord: listening on HOST:PORT" line each prints
(as tools/demo.sh does). The daemons run in their own session, so a Ctrl-C in
the terminal reaches yamor-optimize (which stops and keeps its results) but
not the daemons, which the pool then stops with SIGTERM; on Linux they also get
SIGTERM should this Python process die without cleaning up. `DaemonPool.existing`
wraps daemons someone else started (`--hosts`) and never stops them.

Not thread-safe: one thread owns a pool and its runs.
"""

from __future__ import annotations

import os
import re
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
LISTENING = re.compile(r"^yamord: listening on (\S+:\d+)$")
START_TIMEOUT = 60.0
STOP_TIMEOUT = 30.0
# yamor-optimize writes its summary after SIGINT; give it this long.
OPTIMIZE_STOP_TIMEOUT = 60.0


class ToolError(RuntimeError):
    """A binary is missing, a daemon did not start, or a run failed; the message says which."""


def binaries(build: str | os.PathLike) -> dict[str, Path]:
    """The yamord, yamor-optimize and plugin folder of a build tree (relative paths: to the repo).

    Raises ToolError naming the first missing file.
    """
    build_dir = Path(build)
    if not build_dir.is_absolute():
        build_dir = REPO / build_dir
    found = {
        "yamord": build_dir / "host" / "yamord",
        "optimize": build_dir / "optimizer-plugins" / "yamor-optimize",
        "plugins": build_dir / "plugins",
    }
    for name, path in found.items():
        if not path.exists():
            raise ToolError(f"{path} does not exist (build {build_dir} first, or pass --build)")
    return found


def _die_with_parent() -> None:
    """Runs in the child before exec: SIGTERM when the parent dies (Linux only)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def _read_line(stream, deadline: float) -> str:
    """One line of `stream`, or "" at EOF or when `deadline` (monotonic) passes."""
    remaining = deadline - time.monotonic()
    if remaining <= 0:
        return ""
    ready, _, _ = select.select([stream], [], [], remaining)
    return stream.readline() if ready else ""


def _stop(proc: subprocess.Popen, sig: int, timeout: float) -> int:
    """Sends `sig` (if still running), waits up to `timeout`, then kills; returns the exit status."""
    if proc.poll() is None:
        try:
            proc.send_signal(sig)
        except ProcessLookupError:
            pass
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


class DaemonPool:
    """Addresses of yamord hosts; stops the daemons it started when closed (context manager)."""

    def __init__(self, hosts: list[str], procs: list[subprocess.Popen] | None = None,
                 logs: list[Path] | None = None):
        self.hosts = hosts
        self._procs = procs or []
        self._logs = logs or []

    @classmethod
    def existing(cls, spec: str) -> "DaemonPool":
        """A pool of running daemons: "H:P,H:P" or "@FILE" (one per line, # comments)."""
        if spec.startswith("@"):
            lines = Path(spec[1:]).read_text().splitlines()
            hosts = [line.split("#", 1)[0].strip() for line in lines]
        else:
            hosts = [h.strip() for h in spec.split(",")]
        hosts = [h for h in hosts if h]
        if not hosts:
            raise ToolError(f"--hosts {spec!r} names no host")
        return cls(hosts)

    @classmethod
    def start(cls, yamord: Path, count: int, log_dir: Path, workers: int = 1,
              quiet: bool = False) -> "DaemonPool":
        """Starts `count` daemons with `workers` Evaluate workers each on ephemeral ports.

        Their stderr goes to log_dir/yamordN.log. Raises ToolError (after stopping
        the ones that did start) when one does not report its port within 60 s.
        """
        if count < 1:
            raise ToolError(f"daemon count must be at least 1, got {count}")
        log_dir.mkdir(parents=True, exist_ok=True)
        pool = cls([], [], [])
        try:
            for i in range(count):
                log = log_dir / f"yamord{i + 1}.log"
                with open(log, "w") as stderr:
                    proc = subprocess.Popen(
                        [str(yamord), "--listen", "127.0.0.1:0", "--workers", str(workers),
                         "--log-level", "warn"],
                        stdout=subprocess.PIPE, stderr=stderr, stdin=subprocess.DEVNULL, text=True,
                        cwd=REPO, start_new_session=True, preexec_fn=_die_with_parent)
                pool._procs.append(proc)
                pool._logs.append(log)
            deadline = time.monotonic() + START_TIMEOUT
            for proc, log in zip(pool._procs, pool._logs):
                line = _read_line(proc.stdout, deadline).strip()
                match = LISTENING.match(line)
                if not match:
                    raise ToolError(f"yamord did not report its port (got {line!r}); see {log}")
                pool.hosts.append(match.group(1))
        except BaseException:
            pool.close()
            raise
        if not quiet:
            print(f"daemons: {count} yamord ({workers} worker each) on {pool.hosts_arg()}, "
                  f"pids {','.join(str(p.pid) for p in pool._procs)}", flush=True)
        return pool

    def hosts_arg(self) -> str:
        """The pool as yamor-optimize's --hosts value."""
        return ",".join(self.hosts)

    def running(self) -> bool:
        """True when every daemon this pool started is still running (always for existing ones)."""
        return all(proc.poll() is None for proc in self._procs)

    def close(self) -> None:
        """Stops (SIGTERM, then SIGKILL after 30 s) every daemon this pool started."""
        procs, self._procs = self._procs, []
        for proc in procs:
            if proc.poll() is None:
                try:
                    proc.send_signal(signal.SIGTERM)
                except ProcessLookupError:
                    pass
        for proc in procs:
            _stop(proc, signal.SIGTERM, STOP_TIMEOUT)
            if proc.stdout:
                proc.stdout.close()

    def __enter__(self) -> "DaemonPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_pool(args, bins: dict[str, Path], log_dir: Path) -> DaemonPool:
    """The pool the command line asks for: `args.hosts` if given, else `args.daemons` local daemons."""
    if args.hosts:
        return DaemonPool.existing(args.hosts)
    return DaemonPool.start(bins["yamord"], args.daemons, log_dir, quiet=args.quiet)


def run_optimize(optimize: Path, argv: list[str], quiet: bool = False,
                 log: Path | None = None) -> None:
    """Runs yamor-optimize with `argv`; raises ToolError when it exits non-zero.

    Output goes to the terminal, or with `quiet` to `log` (or nowhere). On
    Ctrl-C (KeyboardInterrupt) or SIGTERM it gets SIGINT and up to 60 s to
    write its results before it is killed, and the interrupt propagates.
    """
    command = [str(optimize), *argv]
    if quiet:
        command[1:1] = ["--quiet", "--log-level", "warn"]
    out = open(log, "w") if (quiet and log) else (subprocess.DEVNULL if quiet else None)
    try:
        proc = subprocess.Popen(command, cwd=REPO, stdout=out, stderr=subprocess.STDOUT if quiet else None,
                                stdin=subprocess.DEVNULL, preexec_fn=_die_with_parent)
        try:
            code = proc.wait()
        except BaseException:
            _stop(proc, signal.SIGINT, OPTIMIZE_STOP_TIMEOUT)
            raise
    finally:
        if out not in (None, subprocess.DEVNULL):
            out.close()
    if code != 0:
        where = f"; see {log}" if (quiet and log) else ""
        raise ToolError(f"yamor-optimize exited with status {code}{where}: {' '.join(command)}")


def sigterm_raises_interrupt() -> None:
    """Turns SIGTERM into KeyboardInterrupt so `with DaemonPool` blocks clean up on it too."""

    def handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    signal.signal(signal.SIGTERM, handler)


def default_daemons() -> int:
    """One single-worker daemon per core."""
    return os.cpu_count() or 1


def main_guard(main) -> int:
    """Calls main(); maps ToolError to exit 1 and Ctrl-C/SIGTERM to 130 with a message."""
    # A background job of a non-interactive shell (`tool &` in a script or CI)
    # starts with SIGINT ignored, and Python keeps an inherited SIG_IGN; then
    # `kill -INT` did nothing and the daemons and yamor-optimize ran on.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sigterm_raises_interrupt()
    try:
        return main()
    except ToolError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted; daemons stopped, partial results kept", file=sys.stderr)
        return 130
