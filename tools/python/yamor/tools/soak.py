"""Bounded soak of one yamord: many clients, mixed calls, killed clients, RSS watched.

    yamor-soak --yamord build/asan/host/yamord --duration 600
    make soak SOAK_TIME=600          # the same, building the asan yamord first

Starts YAMORD on an ephemeral loopback port and hammers it for --duration
seconds with --clients concurrent clients (--processes yamor.tools.soak_client
processes of clients/processes threads each): valid and invalid calls of
every RPC, Evaluate batches, WatchState and RecordFrames streams opened and
dropped. Every --kill-every seconds one client process is SIGKILLed (one
with a stream open when there is one) and a new one started in its place.

The daemon's resident set (VmRSS) is sampled every second. The cold-start
value is reported only: the growth check compares the median over the
--rss-window seconds right after the warm-up (--warmup; by then thread
pools, arenas and, under ASan, the allocator quarantine have filled) with the
median over the last --rss-window seconds of the load.

Exits 0 when the soak passed. Exits 1, with the reason on stderr, when the
daemon died, wrote a sanitizer report (AddressSanitizer, LeakSanitizer,
UBSan "runtime error:", ThreadSanitizer) to its stderr, answered a code it
must never send (INTERNAL, UNKNOWN, DATA_LOSS), stopped answering (no call
succeeded for --stall seconds), failed the final health check, did not exit
0 on SIGTERM, or grew its RSS by more than --max-rss-growth percent.
The working directory (--workdir; a temporary one by default) keeps the
daemon's stderr and the client processes' stderr; it is removed when the
soak passed unless --keep is given. --report FILE writes the figures as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

from yamor import launcher
from yamor.checkout import REPO
from yamor.launcher import describe_exit


SANITIZER = re.compile(r"ERROR: (AddressSanitizer|LeakSanitizer|MemorySanitizer)|"
                       r"WARNING: ThreadSanitizer|runtime error:|"
                       r"SUMMARY: (AddressSanitizer|UndefinedBehaviorSanitizer|ThreadSanitizer)")
# Sanitizer options when the caller has not set them: stop at the first
# report (so it is a crash the soak sees at once); leaks are not checked at
# exit (a growing RSS is the soak's leak check; see the asan test preset).
DEFAULT_ENV = {
    "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=1:halt_on_error=1",
    "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1",
}
BAD_CODES = ("INTERNAL", "UNKNOWN", "DATA_LOSS")


class SoakFailure(Exception):
    """The soak found a problem; the message says which."""


# ---- pure checks (unit-tested in tests/python/test_soak.py) -------------------------

def sanitizer_reports(text: str, limit: int = 5) -> List[str]:
    """Lines of `text` that start a sanitizer report, at most `limit`."""
    return [line.strip() for line in text.splitlines() if SANITIZER.search(line)][:limit]


def rss_growth(samples: Sequence[Tuple[float, int]], warm_end: float, end: float,
               window: float) -> Tuple[int, int, float]:
    """(warm RSS, end RSS, growth %) from (time, kB) samples.

    Warm: median over [warm_end, warm_end + window); end: median over
    [end - window, end]. SoakFailure when a window has no sample.
    """
    warm = [kb for t, kb in samples if warm_end <= t < warm_end + window]
    last = [kb for t, kb in samples if end - window <= t <= end]
    if not warm or not last:
        raise SoakFailure(f"no RSS samples in the warm window at {warm_end:.0f} s or the end "
                          f"window at {end:.0f} s (is the run shorter than warm-up + 2 windows?)")
    w, e = int(statistics.median(warm)), int(statistics.median(last))
    return w, e, 100.0 * (e - w) / w


def vm_rss_kb(pid: int) -> Optional[int]:
    """VmRSS of `pid` in kB, or None when it is gone."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except (FileNotFoundError, ProcessLookupError):
        return None
    return None


# ---- the daemon -----------------------------------------------------------------------

class Daemon(launcher.Daemon):
    """yamord started by yamor.launcher on 127.0.0.1:0, stderr to a file scanned for sanitizer reports."""

    def __init__(self, binary: Path, workdir: Path, extra: Sequence[str]) -> None:
        env = dict(os.environ)
        for key, value in DEFAULT_ENV.items():
            env.setdefault(key, value)
        self.env_used = {k: env[k] for k in DEFAULT_ENV}
        self._scanned = 0
        super().__init__(binary, extra, log=workdir / "yamord.stderr", env=env, check=False)
        deadline = time.monotonic() + 180.0
        try:
            self.wait_started(deadline)
            self.wait_healthy(deadline)
        except launcher.LaunchError as e:
            raise SoakFailure(str(e)) from None

    def stderr_text(self) -> str:
        return self.log_text()

    def new_reports(self) -> List[str]:
        """Sanitizer report lines written to stderr since the last call."""
        with open(self.log, "rb") as f:
            f.seek(self._scanned)
            chunk = f.read()
        # Scan whole lines only; a partial last line waits for the next call.
        cut = chunk.rfind(b"\n") + 1
        self._scanned += cut
        return sanitizer_reports(chunk[:cut].decode(errors="replace"))


# ---- client processes -----------------------------------------------------------------

@dataclass
class Worker:
    """One soak_client.py process and what it reported."""

    proc: subprocess.Popen
    seed: int
    stderr_path: Path
    open_streams: int = 0
    final: bool = False
    reader: Optional[threading.Thread] = None
    ready: threading.Event = field(default_factory=threading.Event)  # first report read


@dataclass
class Tally:
    """Counts from every client process, thread-safe."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    counts: Counter = field(default_factory=Counter)
    bad: List[str] = field(default_factory=list)
    last_ok: float = field(default_factory=time.monotonic)

    def add(self, line: dict) -> None:
        with self.lock:
            for key, n in line.get("counts", {}).items():
                self.counts[key] += n
                if key.endswith(" OK") and n:
                    self.last_ok = time.monotonic()
            self.bad.extend(line.get("bad", []))

    def total(self) -> int:
        with self.lock:
            return sum(self.counts.values())


class Clients:
    """The client processes: start, read, kill, replace, stop."""

    def __init__(self, address: str, processes: int, threads: int, seed: int,
                 workdir: Path, tally: Tally) -> None:
        self.address = address
        self.threads = threads
        self.workdir = workdir
        self.tally = tally
        self.rng = random.Random(seed)
        self.next_seed = seed * 10007
        self.workers: List[Worker] = [self._start() for _ in range(processes)]
        self.kills = 0
        self.kills_mid_stream = 0
        self.started = processes

    def _start(self) -> Worker:
        self.next_seed += 1
        stderr_path = self.workdir / f"client-{self.next_seed}.stderr"
        with open(stderr_path, "w") as stderr:
            proc = subprocess.Popen(
                [sys.executable, "-m", "yamor.tools.soak_client", self.address,
                 "--threads", str(self.threads), "--seed", str(self.next_seed)],
                stdout=subprocess.PIPE, stderr=stderr, text=True, cwd=REPO)
        worker = Worker(proc, self.next_seed, stderr_path)
        worker.reader = threading.Thread(target=self._read, args=(worker,), daemon=True)
        worker.reader.start()
        return worker

    def _read(self, worker: Worker) -> None:
        for line in worker.proc.stdout:
            try:
                report = json.loads(line)
            except json.JSONDecodeError:
                continue
            self.tally.add(report)
            worker.open_streams = report.get("open", 0)
            worker.final = bool(report.get("final"))
            worker.ready.set()

    def check_alive(self) -> None:
        """SoakFailure when a client process ended on its own (a soak bug)."""
        for w in self.workers:
            if w.proc.poll() is not None:
                raise SoakFailure(f"soak client (seed {w.seed}) ended on its own, "
                                  f"{describe_exit(w.proc.returncode)}:\n"
                                  f"{w.stderr_path.read_text(errors='replace')[-3000:]}")

    def wait_ready(self, timeout: float) -> None:
        """Waits until every client process runs (Python and grpc load slowly on a busy machine)."""
        deadline = time.monotonic() + timeout
        for w in self.workers:
            if not w.ready.wait(max(0.0, deadline - time.monotonic())):
                self.check_alive()
                raise SoakFailure(f"soak client (seed {w.seed}) did not start within {timeout:.0f} s")

    def kill_one(self) -> None:
        """SIGKILLs a running client process (one with a stream open when there is one), starts another."""
        running = [w for w in self.workers if w.ready.is_set()]
        if not running:
            return  # all still starting: nothing to kill mid-stream
        streaming = [w for w in running if w.open_streams > 0]
        victim = self.rng.choice(streaming or running)
        victim.proc.kill()
        victim.proc.wait()
        victim.reader.join(timeout=5)
        victim.proc.stdout.close()
        self.kills += 1
        self.kills_mid_stream += bool(streaming)
        self.workers[self.workers.index(victim)] = self._start()
        self.started += 1

    def stop(self, timeout: float) -> None:
        for w in self.workers:
            if w.proc.poll() is None:
                w.proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + timeout
        stuck = []
        for w in self.workers:
            try:
                w.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                w.proc.kill()
                w.proc.wait()
                stuck.append(w.seed)
            w.reader.join(timeout=5)
            w.proc.stdout.close()
        if stuck:
            raise SoakFailure(f"soak clients {stuck} did not stop within {timeout:.0f} s of SIGTERM "
                              "(calls have deadlines: the daemon stopped answering?)")
        # A process started just before the stop may meet SIGTERM before it
        # installs its handler: ended by our signal, it is no failure.
        failed = [w for w in self.workers if w.proc.returncode not in (0, -signal.SIGTERM)]
        if failed:
            w = failed[0]
            raise SoakFailure(f"soak client (seed {w.seed}) failed, "
                              f"{describe_exit(w.proc.returncode)}:\n"
                              f"{w.stderr_path.read_text(errors='replace')[-3000:]}")

    def kill_all(self) -> None:
        for w in self.workers:
            if w.proc.poll() is None:
                w.proc.kill()
                w.proc.wait()


# ---- the run ---------------------------------------------------------------------------

def final_health(address: str) -> None:
    """The daemon still serves: GetInfo, health SERVING, a valid Evaluate with a finite result."""
    import grpc
    from google.protobuf import empty_pb2
    from yamor.v1 import host_pb2 as pb
    from yamor.v1 import host_pb2_grpc as pb_grpc
    from grpc_health.v1 import health_pb2, health_pb2_grpc

    with grpc.insecure_channel(address) as channel:
        try:
            stub = pb_grpc.HostStub(channel)
            stub.SetFreeRun(pb.SetFreeRunRequest(real_time_factor=0), timeout=60)
            info = stub.GetInfo(empty_pb2.Empty(), timeout=60)
            health = health_pb2_grpc.HealthStub(channel).Check(
                health_pb2.HealthCheckRequest(), timeout=60)
            result = stub.Evaluate(pb.EvaluateRequest(world="quadruped", warmup=0.5, duration=1.0,
                                                      seed=7), timeout=120)
        except grpc.RpcError as e:
            raise SoakFailure(f"final health check failed: {e.code().name}: {e.details()}")
    if not info.version or health.status != health_pb2.HealthCheckResponse.SERVING:
        raise SoakFailure(f"final health check: version {info.version!r}, health {health.status}")
    if result.diverged or not (result.distance == result.distance):
        raise SoakFailure(f"final Evaluate of the quadruped went wrong: {result}")


def run(args: argparse.Namespace, workdir: Path) -> dict:
    extra = ["--workers", str(args.workers), "--log-level", args.log_level, *args.yamord_arg]
    daemon = Daemon(Path(args.yamord), workdir, extra)
    cold = vm_rss_kb(daemon.pid)
    print(f"soak: yamord pid {daemon.pid} on {daemon.address}, {args.clients} clients in "
          f"{args.processes} processes, {args.duration:.0f} s (warm-up {args.warmup:.0f} s), "
          f"cold RSS {cold} kB", flush=True)
    tally = Tally()
    clients = Clients(daemon.address, args.processes, args.clients // args.processes, args.seed,
                      workdir, tally)
    try:
        clients.wait_ready(timeout=180.0)
    except SoakFailure:
        clients.kill_all()
        daemon.kill()
        raise
    # The clock starts when every client runs.
    t0 = time.monotonic()
    elapsed = lambda: time.monotonic() - t0  # noqa: E731
    tally.last_ok = t0
    samples: List[Tuple[float, int]] = [(0.0, vm_rss_kb(daemon.pid) or 0)]
    kill_rng = random.Random(args.seed + 1)
    next_kill = args.kill_every * kill_rng.uniform(0.5, 1.5)
    next_progress = args.progress
    next_sample = 1.0
    failure: Optional[str] = None
    try:
        while elapsed() < args.duration:
            time.sleep(0.1)
            code = daemon.proc.poll()
            if code is not None:
                raise SoakFailure(f"yamord died after {elapsed():.1f} s ({describe_exit(code)}); "
                                  f"last lines of its stderr ({daemon.log}):\n{daemon.tail()}")
            reports = daemon.new_reports() if elapsed() >= next_sample else []
            if reports:
                raise SoakFailure("sanitizer report in yamord's stderr:\n" + "\n".join(reports))
            clients.check_alive()
            if elapsed() >= next_sample:
                kb = vm_rss_kb(daemon.pid)
                if kb is not None:
                    samples.append((elapsed(), kb))
                next_sample += 1.0
            if time.monotonic() - tally.last_ok > args.stall:
                raise SoakFailure(f"no call succeeded for {args.stall:.0f} s (at {elapsed():.0f} s): "
                                  "the daemon stopped answering")
            with tally.lock:
                if tally.bad:
                    raise SoakFailure("yamord answered a code it must never send:\n" +
                                      "\n".join(tally.bad[:10]))
            if args.kill_every > 0 and elapsed() >= next_kill:
                clients.kill_one()
                next_kill = elapsed() + args.kill_every * kill_rng.uniform(0.5, 1.5)
            if elapsed() >= next_progress:
                print(f"soak: {elapsed():5.0f} s  {tally.total():8d} calls  "
                      f"RSS {samples[-1][1]} kB  kills {clients.kills}", flush=True)
                next_progress += args.progress
        end = elapsed()
        clients.stop(timeout=args.client_stop)
        with tally.lock:
            if tally.bad:
                raise SoakFailure("yamord answered a code it must never send:\n" +
                                  "\n".join(tally.bad[:10]))
        if daemon.proc.poll() is not None:
            raise SoakFailure(f"yamord died ({describe_exit(daemon.proc.returncode)}):\n"
                              f"{daemon.tail()}")
        final_health(daemon.address)
        warm, last, growth = rss_growth(samples, args.warmup, end, args.rss_window)
        peak = max(kb for _, kb in samples)
        daemon.send_signal(signal.SIGTERM)
        try:
            daemon.proc.wait(timeout=120)
        except subprocess.TimeoutExpired:
            daemon.kill()
            raise SoakFailure("yamord did not exit within 120 s of SIGTERM")
        exit_code = daemon.stop(check=False)
        reports = sanitizer_reports(daemon.stderr_text())
        if reports:
            raise SoakFailure("sanitizer report in yamord's stderr:\n" + "\n".join(reports))
        if exit_code != 0:
            raise SoakFailure(f"yamord {describe_exit(exit_code)} after SIGTERM:\n{daemon.tail()}")
    except SoakFailure as e:
        failure = str(e)
        clients.kill_all()
        daemon.kill()
        # A report written while the daemon was going down.
        reports = sanitizer_reports(daemon.stderr_text())
        if reports and "sanitizer report" not in failure:
            failure += "\nsanitizer report in yamord's stderr:\n" + "\n".join(reports)
        raise SoakFailure(failure) from None

    codes: Counter = Counter()
    per_rpc: Dict[str, Dict[str, int]] = {}
    for key, n in tally.counts.items():
        rpc, code = key.split(" ")
        codes[code] += n
        per_rpc.setdefault(rpc, {})[code] = per_rpc.get(rpc, {}).get(code, 0) + n
    figures = {
        "command": " ".join(daemon.command),
        "env": daemon.env_used,
        "duration_s": round(end, 1),
        "clients": args.clients,
        "processes": args.processes,
        "calls": sum(codes.values()),
        "codes": dict(codes.most_common()),
        "per_rpc": dict(sorted(per_rpc.items())),
        "client_processes_killed": clients.kills,
        "killed_with_streams_open": clients.kills_mid_stream,
        "client_processes_started": clients.started,
        "rss_kb": {"cold": cold, "warm": warm, "end": last, "peak": peak},
        "rss_growth_pct": round(growth, 2),
        "warmup_s": args.warmup,
        "rss_window_s": args.rss_window,
        "rss_series_kb": [kb for t, kb in samples if int(t) % 10 == 0],
    }
    if growth > args.max_rss_growth:
        raise SoakFailure(f"yamord's RSS grew {growth:.1f} % after the warm-up "
                          f"({warm} kB -> {last} kB; limit {args.max_rss_growth} %)\n"
                          + json.dumps(figures["rss_series_kb"]))
    if figures["calls"] == 0 or codes["OK"] == 0:
        raise SoakFailure(f"no successful call in the whole soak: {dict(codes)}")
    return figures


def print_figures(f: dict) -> None:
    rss = f["rss_kb"]
    print(f"soak passed: {f['duration_s']} s, {f['calls']} calls from {f['clients']} clients "
          f"({f['calls'] / max(f['duration_s'], 1e-9):.0f}/s)")
    print("  codes: " + ", ".join(f"{c} {n}" for c, n in f["codes"].items()))
    print(f"  client processes SIGKILLed: {f['client_processes_killed']} "
          f"({f['killed_with_streams_open']} with streams open)")
    print(f"  RSS: cold {rss['cold']} kB, after {f['warmup_s']:.0f} s warm-up {rss['warm']} kB, "
          f"end {rss['end']} kB ({f['rss_growth_pct']:+.1f} %), peak {rss['peak']} kB "
          f"(medians over {f['rss_window_s']:.0f} s)")


def parse_args(argv: Optional[Sequence[str]] = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n".join(__doc__.splitlines()[2:]))
    p.add_argument("--yamord", default=str(REPO / "build" / "asan" / "host" / "yamord"))
    p.add_argument("--duration", type=float, default=600.0, help="seconds of load (600)")
    p.add_argument("--warmup", type=float, default=None,
                   help="seconds before the RSS baseline (default: 15 %% of the duration, "
                        "at most 90 s)")
    p.add_argument("--rss-window", type=float, default=None,
                   help="seconds of RSS samples per median (default: 5 %% of the duration, "
                        "2 to 30 s)")
    p.add_argument("--max-rss-growth", type=float, default=10.0, help="percent (10)")
    p.add_argument("--clients", type=int, default=64)
    p.add_argument("--processes", type=int, default=8, help="client processes (8)")
    p.add_argument("--kill-every", type=float, default=10.0,
                   help="mean seconds between SIGKILLed client processes (10; 0: none)")
    p.add_argument("--workers", type=int, default=2, help="yamord --workers (2)")
    p.add_argument("--log-level", default="warn", help="yamord --log-level (warn)")
    p.add_argument("--yamord-arg", action="append", default=[],
                   help="one more argument for yamord (repeatable)")
    p.add_argument("--seed", type=int, default=1, help="seed of every random choice (1)")
    p.add_argument("--stall", type=float, default=120.0,
                   help="fail when no call succeeded for this many seconds (120)")
    p.add_argument("--client-stop", type=float, default=180.0,
                   help="seconds the clients get to stop after SIGTERM (180)")
    p.add_argument("--progress", type=float, default=30.0, help="seconds between progress lines")
    p.add_argument("--workdir", help="keep logs here (default: a temporary directory)")
    p.add_argument("--keep", action="store_true", help="keep the working directory")
    p.add_argument("--report", help="write the figures as JSON to this file")
    args = p.parse_args(argv)
    if args.warmup is None:
        args.warmup = min(90.0, 0.15 * args.duration)
    if args.rss_window is None:
        args.rss_window = max(2.0, min(30.0, 0.05 * args.duration))
    if args.clients < 1 or args.processes < 1 or args.clients % args.processes:
        p.error(f"--clients {args.clients} must be a positive multiple of --processes "
                f"{args.processes}")
    if args.warmup + 2 * args.rss_window > args.duration:
        p.error(f"--duration {args.duration} is shorter than the warm-up ({args.warmup}) plus "
                f"two RSS windows ({args.rss_window})")
    return args


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = parse_args(argv)
    if not Path(args.yamord).is_file():
        print(f"soak: {args.yamord} does not exist (make soak builds the asan yamord)",
              file=sys.stderr)
        return 2
    workdir = Path(args.workdir) if args.workdir else Path(tempfile.mkdtemp(prefix="yamor-soak-"))
    workdir.mkdir(parents=True, exist_ok=True)
    try:
        figures = run(args, workdir)
    except SoakFailure as e:
        print(f"soak FAILED: {e}\n(logs in {workdir})", file=sys.stderr)
        return 1
    print_figures(figures)
    if args.report:
        Path(args.report).write_text(json.dumps(figures, indent=2) + "\n")
    if args.workdir is None and not args.keep:
        shutil.rmtree(workdir, ignore_errors=True)
    else:
        print(f"  logs in {workdir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
