"""A pool of yamord daemons (started here or already running) and yamor-optimize runs that stop cleanly.

Shared by yamor.tools.reproduce and the benchmarks (yamor.tools.*_bench).

    with DaemonPool.start(yamord, count=2, log_dir=out) as pool:
        run_optimize(optimize, [..., "--hosts", pool.hosts_arg()])

`DaemonPool.start` launches `count` daemons (`--workers 1 --log-level warn`)
with yamor.launcher, which stops them with SIGTERM when the pool closes (a
Ctrl-C in the terminal reaches yamor-optimize, which stops and keeps its
results, not the daemons) and never lets them outlive this process.
`DaemonPool.existing` wraps daemons someone else started (`--hosts`) and
never stops them.

Not thread-safe: one thread owns a pool and its runs.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Optional

from yamor.checkout import REPO
from yamor.launcher import Daemons, LaunchError, die_with_parent, start_daemons

START_TIMEOUT = 60.0
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

    def __init__(self, hosts: list[str], daemons: Optional[Daemons] = None):
        self.hosts = hosts
        self._daemons = daemons

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
        the ones that did start) when one does not serve within 60 s.
        """
        try:
            daemons = start_daemons(count, yamord, ["--workers", str(workers), "--log-level", "warn"],
                                    log_dir=log_dir, timeout=START_TIMEOUT)
        except LaunchError as error:
            raise ToolError(str(error)) from None
        if not quiet:
            print(f"daemons: {count} yamord ({workers} worker each) on {daemons.hosts_arg()}, "
                  f"pids {','.join(str(d.pid) for d in daemons)}", flush=True)
        return cls(daemons.addresses, daemons)

    def hosts_arg(self) -> str:
        """The pool as yamor-optimize's --hosts value."""
        return ",".join(self.hosts)

    def running(self) -> bool:
        """True when every daemon this pool started is still running (always for existing ones)."""
        return self._daemons is None or self._daemons.running()

    def close(self, check: bool = True) -> None:
        """Stops (SIGTERM, then SIGKILL after 30 s) every daemon this pool started.

        With `check`, ToolError when one did not exit 0.
        """
        daemons, self._daemons = self._daemons, None
        if daemons is not None:
            try:
                daemons.stop(check=check)
            except LaunchError as error:
                raise ToolError(str(error)) from None

    def __enter__(self) -> "DaemonPool":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close(check=exc_type is None)


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
                                stdin=subprocess.DEVNULL, preexec_fn=die_with_parent)
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
    """Calls main(); maps ToolError and LaunchError to exit 1 and Ctrl-C/SIGTERM to 130 with a message."""
    # A background job of a non-interactive shell (`tool &` in a script or CI)
    # starts with SIGINT ignored, and Python keeps an inherited SIG_IGN; then
    # `kill -INT` did nothing and the daemons and yamor-optimize ran on.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sigterm_raises_interrupt()
    try:
        return main()
    except (ToolError, LaunchError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted; daemons stopped, partial results kept", file=sys.stderr)
        return 130
