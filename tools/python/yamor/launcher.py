"""Start local yamord daemons, wait until they serve, stop them and check how they ended.

    from yamor.launcher import start_daemons

    with start_daemons(2, args=["--workers", "1"], log_dir=out) as daemons:
        run_something(daemons.hosts_arg())        # "127.0.0.1:41234,127.0.0.1:41235"
    # stopped here with SIGTERM; LaunchError when one did not exit 0

Each daemon listens on an ephemeral loopback port (``--listen 127.0.0.1:0``
unless the arguments name ``--listen``); the address is read from the line
``yamord: listening on HOST:PORT`` it prints, then the gRPC health service is
polled until it answers SERVING. A started daemon never outlives this process:
``with`` blocks and ``stop()`` end it; what is still running when the
interpreter exits is stopped by an ``atexit`` hook; and on Linux the kernel
sends it SIGTERM when the thread that started it dies, so a SIGKILLed parent
leaks nothing either (start daemons from a thread that lives as long as they
do: the main thread). Daemons run in their own session, so a Ctrl-C in the
terminal reaches only this process, which then stops them cleanly.

Not thread-safe: one thread owns a Daemon or a Daemons group.
"""

from __future__ import annotations

import atexit
import os
import re
import select
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Iterator, List, Mapping, Optional, Sequence, Union

from yamor import checkout

PathLike = Union[str, os.PathLike]

#: The line yamord prints on stdout once its port is bound.
LISTENING = re.compile(r"^yamord: listening on (\S+:\d+)$")
#: Seconds a daemon gets to print its port and answer the health service.
START_TIMEOUT = 60.0
#: Seconds a daemon gets to drain after SIGTERM before it is killed.
STOP_TIMEOUT = 30.0

# Every daemon started and not yet stopped, for the atexit hook.
_running: "set[Daemon]" = set()


class LaunchError(RuntimeError):
    """A daemon is missing, did not start, or did not exit 0; the message says which."""


def default_yamord() -> Path:
    """$YAMORD, else the checkout's build/release/host/yamord, else `yamord` on PATH."""
    if os.environ.get("YAMORD"):
        return Path(os.environ["YAMORD"])
    built = checkout.RELEASE / "host" / "yamord"
    if built.is_file():
        return built
    found = shutil.which("yamord")
    return Path(found) if found else built


def die_with_parent() -> None:
    """Runs in the child before exec: SIGTERM when the parent's thread dies (Linux only)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def describe_exit(code: Optional[int]) -> str:
    """"exit status N" or "killed by SIGNAME" for a Popen return code."""
    if code is None:
        return "still running"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


class Daemon:
    """One yamord started by this process (see the module's documentation).

    Built by :func:`start_daemon` or :func:`start_daemons`; a context manager
    that stops it (and, with ``check``, raises LaunchError unless it exited 0).
    """

    def __init__(self, yamord: Optional[PathLike] = None, args: Sequence[str] = (), *,
                 log: Optional[PathLike] = None, env: Optional[Mapping[str, str]] = None,
                 cwd: Optional[PathLike] = None, check: bool = True) -> None:
        """Spawns the process; :meth:`wait_started` then reads its address."""
        binary = Path(yamord) if yamord is not None else default_yamord()
        if not binary.is_file():
            raise LaunchError(f"yamord not found: {binary} does not exist "
                              "(make build, or set YAMORD)")
        args = [str(a) for a in args]
        listen = [] if any(a == "--listen" or a.startswith("--listen=") for a in args) \
            else ["--listen", "127.0.0.1:0"]
        self.command: List[str] = [str(binary), *listen, *args]
        self.check = check
        self._own_log = log is None
        if log is None:
            handle, name = tempfile.mkstemp(prefix="yamord-", suffix=".log")
            os.close(handle)
            log = name
        self.log = Path(log)
        self.address = ""
        self.returncode: Optional[int] = None
        with open(self.log, "w") as stderr:
            self.proc = subprocess.Popen(
                self.command, stdout=subprocess.PIPE, stderr=stderr, stdin=subprocess.DEVNULL,
                text=True, cwd=str(cwd or checkout.REPO),
                env=None if env is None else dict(env), start_new_session=True,
                preexec_fn=die_with_parent)
        _running.add(self)

    @property
    def pid(self) -> int:
        """The process id."""
        return self.proc.pid

    def poll(self) -> Optional[int]:
        """The exit status when it has ended (negative: killed by that signal), else None."""
        return self.proc.poll()

    def running(self) -> bool:
        """True while the process runs."""
        return self.proc.poll() is None

    def log_text(self) -> str:
        """Its stderr so far."""
        try:
            return self.log.read_text(errors="replace")
        except FileNotFoundError:
            return ""

    def tail(self, lines: int = 40) -> str:
        """The last `lines` lines of its stderr."""
        return "\n".join(self.log_text().splitlines()[-lines:])

    def _fail(self, what: str) -> LaunchError:
        """Kills it and returns the LaunchError naming `what`, with the log's tail."""
        self.kill()
        return LaunchError(f"{what}; {self.command[0]} {describe_exit(self.returncode)}; "
                           f"last lines of {self.log}:\n{self.tail()}")

    def wait_started(self, deadline: float) -> str:
        """Reads the "listening on" line by `deadline` (time.monotonic); returns the address.

        LaunchError (the daemon killed) when it ends, prints something else, or is late.
        """
        remaining = deadline - time.monotonic()
        ready = select.select([self.proc.stdout], [], [], max(0.0, remaining))[0]
        line = self.proc.stdout.readline().strip() if ready else ""
        match = LISTENING.match(line)
        if not match:
            raise self._fail(f"yamord did not report its port (got {line!r})")
        self.address = match.group(1)
        return self.address

    def wait_healthy(self, deadline: float) -> None:
        """Polls the gRPC health service until it answers SERVING, by `deadline` (monotonic).

        Without the grpcio-health-checking package it waits for the channel to
        connect instead. LaunchError (the daemon killed) when it ends or is late.
        """
        import grpc

        try:
            from grpc_health.v1 import health_pb2, health_pb2_grpc
        except ImportError:
            health_pb2 = health_pb2_grpc = None
        with grpc.insecure_channel(self.address) as channel:
            while True:
                remaining = deadline - time.monotonic()
                if not self.running() or remaining <= 0:
                    raise self._fail(f"yamord on {self.address} did not answer its health service")
                try:
                    if health_pb2 is None:
                        grpc.channel_ready_future(channel).result(timeout=min(remaining, 1.0))
                        return
                    status = health_pb2_grpc.HealthStub(channel).Check(
                        health_pb2.HealthCheckRequest(), timeout=min(remaining, 5.0)).status
                    if status == health_pb2.HealthCheckResponse.SERVING:
                        return
                except (grpc.RpcError, grpc.FutureTimeoutError):
                    pass
                time.sleep(0.05)

    def send_signal(self, sig: int) -> None:
        """Sends `sig` while it runs (a no-op once it has ended)."""
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(sig)
            except ProcessLookupError:
                pass

    def kill(self) -> int:
        """SIGKILLs it (if still running) and returns its exit status."""
        self.send_signal(signal.SIGKILL)
        return self._reap(None)

    def _reap(self, timeout: Optional[float]) -> int:
        """Waits up to `timeout` (None: for ever), kills it after that, releases its pipe."""
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.returncode = self.proc.returncode
        if self.proc.stdout and not self.proc.stdout.closed:
            self.proc.stdout.close()
        _running.discard(self)
        return self.returncode

    def stop(self, timeout: float = STOP_TIMEOUT, sig: int = signal.SIGTERM,
             check: Optional[bool] = None) -> int:
        """Sends `sig`, waits up to `timeout` seconds, then SIGKILLs; returns the exit status.

        With `check` (default: the constructor's) LaunchError unless the status
        is 0. Stopping an ended daemon returns its status again. Its own
        temporary log is removed when it exited 0.
        """
        self.send_signal(sig)
        code = self._reap(timeout)
        if check if check is not None else self.check:
            if code != 0:
                raise LaunchError(f"yamord on {self.address or '?'} (pid {self.pid}) "
                                  f"{describe_exit(code)} after {signal.Signals(sig).name}; "
                                  f"last lines of {self.log}:\n{self.tail()}")
        if self._own_log and code == 0:
            self.log.unlink(missing_ok=True)
        return code

    def __enter__(self) -> "Daemon":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        # An exception in flight wins over a bad exit status.
        self.stop(check=self.check and exc_type is None)

    def __repr__(self) -> str:
        return f"Daemon({self.address or 'starting'}, pid {self.pid})"


def start_daemon(yamord: Optional[PathLike] = None, args: Sequence[str] = (), *,
                 log: Optional[PathLike] = None, env: Optional[Mapping[str, str]] = None,
                 cwd: Optional[PathLike] = None, timeout: float = START_TIMEOUT,
                 healthy: bool = True, check: bool = True) -> Daemon:
    """One yamord with `args`, serving; see :func:`start_daemons`."""
    with start_daemons(1, yamord, args, logs=[log] if log else None, env=env, cwd=cwd,
                       timeout=timeout, healthy=healthy, check=check) as daemons:
        return daemons.release()[0]


class Daemons:
    """Daemons started together; a context manager that stops them all.

    Iterable and indexable like a list of :class:`Daemon`.
    """

    def __init__(self, daemons: List[Daemon], check: bool) -> None:
        self._daemons = daemons
        self.check = check

    def __iter__(self) -> Iterator[Daemon]:
        return iter(self._daemons)

    def __len__(self) -> int:
        return len(self._daemons)

    def __getitem__(self, index: int) -> Daemon:
        return self._daemons[index]

    @property
    def addresses(self) -> List[str]:
        """Each daemon's "HOST:PORT"."""
        return [d.address for d in self._daemons]

    def hosts_arg(self) -> str:
        """The addresses as yamor-optimize's --hosts value ("H:P,H:P")."""
        return ",".join(self.addresses)

    def running(self) -> bool:
        """True while every daemon runs."""
        return all(d.running() for d in self._daemons)

    def release(self) -> List[Daemon]:
        """Hands the daemons to the caller: stopping the group no longer stops them."""
        daemons, self._daemons = self._daemons, []
        return daemons

    def stop(self, timeout: float = STOP_TIMEOUT, check: Optional[bool] = None) -> List[int]:
        """SIGTERMs all at once, waits (SIGKILL after `timeout`); returns their exit statuses.

        With `check` (default: the group's) LaunchError naming the first that did not exit 0.
        """
        for d in self._daemons:
            d.send_signal(signal.SIGTERM)
        codes = [d.stop(timeout, check=False) for d in self._daemons]
        if check if check is not None else self.check:
            for d, code in zip(self._daemons, codes):
                if code != 0:
                    raise LaunchError(f"yamord on {d.address or '?'} (pid {d.pid}) "
                                      f"{describe_exit(code)} after SIGTERM; last lines of "
                                      f"{d.log}:\n{d.tail()}")
        return codes

    def __enter__(self) -> "Daemons":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.stop(check=self.check and exc_type is None)


def start_daemons(count: int, yamord: Optional[PathLike] = None, args: Sequence[str] = (), *,
                  log_dir: Optional[PathLike] = None, logs: Optional[Sequence[PathLike]] = None,
                  env: Optional[Mapping[str, str]] = None, cwd: Optional[PathLike] = None,
                  timeout: float = START_TIMEOUT, healthy: bool = True,
                  check: bool = True) -> Daemons:
    """Starts `count` yamord (default binary: :func:`default_yamord`) with `args`, serving.

    Each daemon's stderr goes to log_dir/yamordN.log (N from 1), to logs[i],
    or to a temporary file removed when it exits 0. `env` replaces the
    environment, `cwd` (default: the checkout) is their working directory.
    They start in parallel; within `timeout` seconds each must print its port
    and, with `healthy`, answer its health service SERVING. Otherwise
    LaunchError, after every daemon started here was stopped. `check`: stopping
    the group (or leaving its ``with`` block without an exception) raises
    LaunchError when a daemon did not exit 0.
    """
    if count < 1:
        raise LaunchError(f"daemon count must be at least 1, got {count}")
    if logs is not None and len(logs) != count:
        raise LaunchError(f"{len(logs)} log files for {count} daemons")
    if logs is None and log_dir is not None:
        Path(log_dir).mkdir(parents=True, exist_ok=True)
        logs = [Path(log_dir) / f"yamord{i + 1}.log" for i in range(count)]
    group = Daemons([], check)
    try:
        for i in range(count):
            group._daemons.append(Daemon(yamord, args, log=logs[i] if logs else None, env=env,
                                         cwd=cwd, check=check))
        deadline = time.monotonic() + timeout
        for d in group:
            d.wait_started(deadline)
        if healthy:
            for d in group:
                d.wait_healthy(deadline)
    except BaseException:
        group.stop(timeout=5.0, check=False)
        raise
    return group


@atexit.register
def _stop_leftovers() -> None:
    """Stops the daemons nobody stopped (a script that forgot, an unhandled exception)."""
    for d in list(_running):
        d.stop(timeout=10.0, check=False)
