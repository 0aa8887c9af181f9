"""Lifelong-learning benchmark (issue 13 §5): yamor-lifelong on the scenarios of configs/lifelong.

Usage: yamor-lifelong-bench [--parts transform,latency,recall,false-alarm] [--seeds 5 | --seed-list 4,5]
                            [--daemons N] [--out results/lifelong-bench] [--build build/release]
                            [--online-budget 45] [--model-budget 250] [--offline-budget 1000]
                            [--false-alarm-time 1800] [--quick]

Parts (each reports trials, robot time and wall time separately, medians over the seeds):

  transform    7.5.1: the quadruped transformed at minute 4 relearns online
               (--online-budget trials: 45 trials of 4 periods are about 10 min of
               robot time) and in model mode (--model-budget simulated evaluations,
               3 verified on the robot). The relearned gaits and the best of the
               offline yamor-optimize runs (--offline-plugins, default powell and
               cmaes with restarts) of --offline-budget evaluations on the
               same generated problem and the transformed body are evaluated alike
               (Evaluate, 8 s + 12 s, evaluation seeds 0-2) and compared, with the
               velocity before the change. Targets: >= 90 % of the offline best
               within <= 10 min of robot time online; within <= 1 min of wall time
               in model mode (2 cores).
  latency      every scenario: windows from the change to the anomaly (target <= 3).
  recall       ground.toml: the second and third anomaly come back from the
               database: trials until recalled (target <= 10; each window of a
               longer trial of a noisy gait counts), no optimization.
  false-alarm  every robot of configs/robots walks its configured gait undisturbed
               for --false-alarm-time seconds of robot time (target: no anomaly).

Lives run in parallel, one per daemon (--daemons, default one per core; each
daemon has 2 Evaluate workers for model mode). The table (Markdown) is printed
and written to OUT/lifelong-bench.md, the per-run numbers to OUT/runs.csv, each
life's output folder to OUT/<part>/<name>/. --quick shrinks everything (1 seed,
short lives, budgets of 3) so tests/python can run it.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
import csv
import json
import os
import queue
import shutil
import sqlite3
import statistics
import subprocess
import sys
import time
from pathlib import Path

from yamor.checkout import REPO
from yamor.tools import daemons
from yamor.tools.daemons import ToolError

SCENARIOS = REPO / "configs" / "lifelong"
SCRIPT = REPO / "configs" / "scripts" / "quadruped-transform.xml"
LATENCY_SCENARIOS = ["transform", "upside_down", "ground", "limp_motor", "stuck_motor", "module_defect",
                     "module_inserted"]
ROBOTS = ["quadruped", "snake", "tripod", "dog", "trebuchet", "wheel"]


def binaries(build: str) -> dict[str, Path]:
    found = daemons.binaries(build)
    base = found["yamord"].parent.parent
    found["lifelong"] = base / "optimizer-plugins" / "lifelong" / "yamor-lifelong"
    found["yamorctl"] = base / "tools" / "yamorctl" / "yamorctl"
    for key in ("lifelong", "yamorctl"):
        if not found[key].exists():
            raise ToolError(f"{found[key]} does not exist (build it, or pass --build)")
    return found


class Hosts:
    """A queue of daemons: each life takes one for itself (`with hosts.take() as host`)."""

    def __init__(self, hosts: list[str]):
        self._free: queue.Queue[str] = queue.Queue()
        for h in hosts:
            self._free.put(h)

    @contextlib.contextmanager
    def take(self):
        host = self._free.get()
        try:
            yield host
        finally:
            self._free.put(host)


def read_events(folder: Path) -> list[dict]:
    path = folder / "events.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def read_timeline(folder: Path) -> list[dict]:
    with open(folder / "timeline.csv", newline="") as f:
        return list(csv.DictReader(f))


def of(events: list[dict], kind: str) -> list[dict]:
    return [e for e in events if e["kind"] == kind]


def scenario_copy(name: str, folder: Path, at: float | None = None, config: Path | None = None) -> Path:
    """The scenario with absolute paths (and the change moved to `at` when given)."""
    text = (SCENARIOS / f"{name}.toml").read_text()
    text = text.replace('config = "', f'config = "{SCENARIOS}/', 1)
    text = text.replace('world = "quadruped-', f'world = "{SCENARIOS}/quadruped-')
    text = text.replace('file = "../', f'file = "{REPO / "configs"}/')
    if at is not None:
        lines, first = [], True
        for line in text.splitlines():
            if first and line.startswith("at = "):
                line, first = f"at = {at}", False
            lines.append(line)
        text = "\n".join(lines) + "\n"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


def live(bins, hosts: Hosts, scenario: Path, out: Path, extra: list[str]) -> dict:
    """Runs one life in a fresh folder; returns its events, timeline and wall time."""
    if out.exists():
        shutil.rmtree(out)
    with hosts.take() as host:
        argv = [str(bins["lifelong"]), "--host", host, "--scenario", str(scenario), "--out", str(out),
                "--no-plot", "--quiet", "--log-level", "warn", *extra]
        started = time.monotonic()
        with open(out.parent / f"{out.name}.log", "w") as log:
            result = subprocess.run(argv, cwd=REPO, stdout=log, stderr=subprocess.STDOUT)
        wall = time.monotonic() - started
    if result.returncode != 0:
        raise ToolError(f"yamor-lifelong exited with {result.returncode}: {' '.join(argv)}; see {out}.log")
    return {"events": read_events(out), "timeline": read_timeline(out), "wall": wall, "out": out}


def window_seconds(timeline: list[dict]) -> float:
    """The walking windows' length (the median gap between consecutive walking rows)."""
    times = [float(r["time"]) for r in timeline if r["state"] == "walking" and r["velocity"]]
    gaps = [b - a for a, b in zip(times, times[1:]) if b > a]
    return statistics.median(gaps) if gaps else float("nan")


def evaluate(bins, host: str, config_xml: str, morphology: Path, folder: Path, tag: str) -> float:
    """Median velocity [m/s] of a gait on a body over evaluation seeds 0-2 (8 s + 12 s)."""
    config = folder / f"{tag}.xml"
    config.write_text(config_xml)
    velocities = []
    for seed in range(3):
        r = subprocess.run([str(bins["yamorctl"]), "--host", host, "--json", "--timeout", "600", "evaluate",
                            "--config", str(config), "--morphology", str(morphology), "--seed", str(seed)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            raise ToolError(f"yamorctl evaluate failed: {r.stderr.strip()}")
        velocities.append(json.loads(r.stdout).get("velocity", 0.0))
    return statistics.median(velocities)


def transformed_morphology(bins, host: str, path: Path) -> Path:
    """The quadruped after the 7.5.1 script, as a morphology file."""
    ctl = [str(bins["yamorctl"]), "--host", host]
    for argv in (["open", "--world", "quadruped"], ["script", str(SCRIPT)], ["morphology", str(path)]):
        r = subprocess.run(ctl + argv, capture_output=True, text=True)
        if r.returncode != 0:
            raise ToolError(f"yamorctl {' '.join(argv)} failed: {r.stderr.strip()}")
    return path


def gait_rows(db: Path) -> list[dict]:
    with sqlite3.connect(db) as c:
        c.row_factory = sqlite3.Row
        return [dict(r) for r in c.execute("SELECT * FROM gaits ORDER BY id")]


def med(values):
    values = [v for v in values if v is not None and v == v]
    return statistics.median(values) if values else None


def fmt(value, digits=2, scale=1.0, unit=""):
    return "-" if value is None else f"{value * scale:.{digits}f}{unit}"


# --- parts --------------------------------------------------------------------

def part_transform(args, bins, hosts: Hosts, pool_hosts: list[str], out: Path, rows: list) -> list[str]:
    folder = out / "transform"
    change = 60 if args.quick else 240
    lives = []
    jobs = []
    with concurrent.futures.ThreadPoolExecutor(len(pool_hosts)) as ex:
        for mode, budget in (("online", args.online_budget), ("model", args.model_budget)):
            for seed in args.seed_list:
                name = f"{mode}-seed-{seed}"
                scenario = scenario_copy("transform", folder / name, at=change)
                extra = ["--mode", mode, "--seed", str(seed), "--max-anomalies", "1",
                         "--set", f"max_evaluations={budget}"] + args.short
                jobs.append((mode, seed, ex.submit(live, bins, hosts, scenario, folder / name / "life", extra)))
        for mode, seed, job in jobs:
            lives.append((mode, seed, job.result()))
    morphology = transformed_morphology(bins, pool_hosts[0], folder / "transformed.xml")
    # The offline reference: the generated problem of the first online life, on the new body.
    first = next(life for mode, _, life in lives if mode == "online")
    gaits = gait_rows(first["out"] / "gaits.sqlite")
    problem = folder / "offline-problem.xml"
    problem.write_text(gaits[-1]["problem_xml"])
    # (b) the best an offline run of --offline-budget evaluations finds: each
    # plugin of --offline-plugins (powell stops when it converges, so CMA-ES
    # with restarts spends the whole budget), the best of them counts.
    offline_v, offline_wall = {}, {}
    for plugin in args.offline_plugins.split(","):
        offline = folder / f"offline-{plugin}"
        started = time.monotonic()
        sets = ["--set", f"max_evaluations={args.offline_budget}"]
        if plugin == "cmaes":
            sets += ["--set", "restarts=9"]
        daemons.run_optimize(bins["optimize"], [
            "--plugin", plugin, "--config", str(problem), "--morphology", str(morphology), "--hosts",
            ",".join(pool_hosts), *sets, "--out", str(offline), "--seed", "1",
            "--no-plot", "--no-video"] + (["--warmup", "1", "--duration", "2"] if args.quick else []), quiet=True,
            log=folder / f"offline-{plugin}.log")
        offline_wall[plugin] = time.monotonic() - started
        offline_v[plugin] = evaluate(bins, pool_hosts[0], (offline / "best.xml").read_text(), morphology, folder,
                                     f"offline-best-{plugin}")
        rows.append({"part": "transform-offline", "name": plugin, "seed": 1, "evaluations": args.offline_budget,
                     "velocity_after": offline_v[plugin], "wall_seconds": offline_wall[plugin]})
    v_offline = max(offline_v.values())
    v_before = evaluate(bins, pool_hosts[0], gaits[0]["config_xml"],
                        REPO / "configs" / "worlds" / "quadruped.xml", folder, "before")
    v_kept = evaluate(bins, pool_hosts[0], gaits[0]["config_xml"], morphology, folder, "old-gait-new-body")
    results = {}
    for mode, seed, life in lives:
        relearned = of(life["events"], "relearned")
        anomaly = of(life["events"], "anomaly")
        if not relearned:
            raise ToolError(f"{life['out']}: no relearned event")
        r = relearned[0]
        g = gait_rows(life["out"] / "gaits.sqlite")[-1]
        v_after = evaluate(bins, pool_hosts[0], g["config_xml"], morphology, folder, f"{mode}-{seed}")
        row = {"part": "transform", "name": mode, "seed": seed, "trials": r["trials"],
               "evaluations": r["evaluations"], "robot_seconds": r["robot_seconds"],
               "wall_seconds": r.get("wall_seconds"), "velocity_after": v_after,
               "velocity_before_ema": anomaly[0]["velocity_before"] if anomaly else None,
               "fraction_of_offline": v_after / v_offline if v_offline > 0 else None}
        rows.append(row)
        results.setdefault(mode, []).append(row)
    lines = [f"### 7.5.1 transformation ({len(args.seed_list)} seed(s); the change at {change} s)", "",
             f"Evaluated alike (Evaluate 8 s + 12 s, median of evaluation seeds 0-2): the old gait on the old "
             f"body {fmt(v_before, scale=100, unit=' cm/s')}, on the new body {fmt(v_kept, scale=100, unit=' cm/s')}; "
             f"offline, at most {args.offline_budget} evaluations on the same generated problem and the new body: "
             + ", ".join(f"{p} {fmt(v, scale=100, unit=' cm/s')} ({offline_wall[p]:.0f} s wall)"
                         for p, v in offline_v.items())
             + f"; the best, {fmt(v_offline, scale=100, unit=' cm/s')}, is the reference.", "",
             "| mode | trials on the robot | evaluations | robot time | relearning wall time | velocity after "
             "| of offline best | of before |", "|---|---|---|---|---|---|---|---|"]
    for mode, rs in results.items():
        v = med([r["velocity_after"] for r in rs])
        lines.append(f"| {mode} | {fmt(med([r['trials'] for r in rs]), 0)} | {fmt(med([r['evaluations'] for r in rs]), 0)} "
                     f"| {fmt(med([r['robot_seconds'] for r in rs]), 0, 1 / 60, ' min')} "
                     f"| {fmt(med([r['wall_seconds'] for r in rs]), 0, 1, ' s')} | {fmt(v, scale=100, unit=' cm/s')} "
                     f"| {fmt(v / v_offline if v and v_offline else None, 0, 100, ' %')} "
                     f"| {fmt(v / v_before if v and v_before else None, 0, 100, ' %')} |")
    return lines


def part_latency(args, bins, hosts: Hosts, pool_hosts: list[str], out: Path, rows: list) -> list[str]:
    folder = out / "latency"
    at = 60 if args.quick else 120
    jobs = []
    with concurrent.futures.ThreadPoolExecutor(len(pool_hosts)) as ex:
        for name in LATENCY_SCENARIOS:
            for seed in args.seed_list:
                scenario = scenario_copy(name, folder / f"{name}-{seed}", at=at)
                extra = ["--seed", str(seed), "--max-anomalies", "1", "--set", "max_evaluations=1",
                         "--max-time", str(at + 200)] + args.short
                jobs.append((name, seed, ex.submit(live, bins, hosts, scenario, folder / f"{name}-{seed}" / "life",
                                                   extra)))
        lines = ["### Detection latency (windows from the change to the anomaly; target <= 3)", "",
                 "| scenario | trigger | latency [windows] | latency [s] |", "|---|---|---|---|"]
        by_name: dict[str, list] = {}
        for name, seed, job in jobs:
            life = job.result()
            change = of(life["events"], "scenario_change")
            anomaly = of(life["events"], "anomaly")
            window = window_seconds(life["timeline"])
            latency = anomaly[0]["time"] - change[0]["time"] if change and anomaly else None
            row = {"part": "latency", "name": name, "seed": seed,
                   "trigger": anomaly[0]["trigger"] if anomaly else "none",
                   "latency_seconds": latency, "latency_windows": latency / window if latency is not None else None}
            rows.append(row)
            by_name.setdefault(name, []).append(row)
    for name, rs in by_name.items():
        triggers = sorted({r["trigger"] for r in rs})
        lines.append(f"| {name} | {', '.join(triggers)} | {fmt(med([r['latency_windows'] for r in rs]), 1)} "
                     f"| {fmt(med([r['latency_seconds'] for r in rs]), 1)} |")
    return lines


def part_recall(args, bins, hosts: Hosts, pool_hosts: list[str], out: Path, rows: list) -> list[str]:
    folder = out / "recall"
    jobs = []
    with concurrent.futures.ThreadPoolExecutor(len(pool_hosts)) as ex:
        for seed in args.seed_list:
            scenario = scenario_copy("ground", folder / f"seed-{seed}")
            extra = ["--seed", str(seed), "--max-anomalies", "3"] + args.short
            if args.quick:
                text = scenario.read_text().replace("at = 1500", "at = 140").replace("at = 2100", "at = 200")
                scenario.write_text(text.replace("at = 120", "at = 40"))
                extra += ["--set", "max_evaluations=3"]
            jobs.append((seed, ex.submit(live, bins, hosts, scenario, folder / f"seed-{seed}" / "life", extra)))
        lines = ["### Recall from the database (ground sticky, back, sticky again)", "",
                 "| seed | anomalies | relearned | recalled | trials per recall | optimizations after the first |",
                 "|---|---|---|---|---|---|"]
        for seed, job in jobs:
            life = job.result()
            ev = life["events"]
            trials, count = [], 0
            for e in ev:
                if e["kind"] == "anomaly":
                    count = 0
                elif e["kind"] == "recall_trial":
                    count += 1
                elif e["kind"] == "recalled":
                    trials.append(count)
            rows.append({"part": "recall", "name": "ground", "seed": seed, "anomalies": len(of(ev, "anomaly")),
                         "relearned": len(of(ev, "relearned")), "recalled": len(of(ev, "recalled")),
                         "trials": ";".join(map(str, trials))})
            lines.append(f"| {seed} | {len(of(ev, 'anomaly'))} | {len(of(ev, 'relearned'))} | "
                         f"{len(of(ev, 'recalled'))} | {', '.join(map(str, trials)) or '-'} | "
                         f"{max(0, len(of(ev, 'relearn')) - 1)} |")
    return lines


def part_false_alarm(args, bins, hosts: Hosts, pool_hosts: list[str], out: Path, rows: list) -> list[str]:
    """Every robot walks its configured gait undisturbed, one life per world seed.

    An anomaly is listed with its trigger and the velocities around it, so a
    reader can tell noise from a real event (a robot that tumbles onto its
    back, a wheel that stalls)."""
    folder = out / "false-alarm"
    jobs = []
    with concurrent.futures.ThreadPoolExecutor(len(pool_hosts)) as ex:
        for robot in args.robots.split(","):
            for seed in args.seed_list:
                path = folder / robot / f"seed-{seed}" / "walk.toml"
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(f'world = "{robot}"\nconfig = "{REPO / "configs" / "robots" / (robot + ".xml")}"\n'
                                f'seed = {seed}\n')
                extra = ["--max-time", str(args.false_alarm_time), "--set", "max_evaluations=1", *args.short]
                jobs.append((robot, seed, ex.submit(live, bins, hosts, path, path.parent / "life", extra)))
        lines = [f"### No false alarm ({args.false_alarm_time:.0f} s of robot time per life, default threshold, "
                 f"world seeds {args.seed_list[0]}-{args.seed_list[-1]})", "",
                 "| robot | seed | windows | anomalies | velocity median (min-max) [cm/s] | anomalies: trigger, "
                 "time, velocity before -> after [cm/s] |",
                 "|---|---|---|---|---|---|"]
        for robot, seed, job in jobs:
            life = job.result()
            walking = [float(r["velocity"]) for r in life["timeline"] if r["state"] == "walking" and r["velocity"]]
            found = of(life["events"], "anomaly")
            rows.append({"part": "false-alarm", "name": robot, "seed": seed, "windows": len(walking),
                         "anomalies": len(found)})
            what = "; ".join(f"{e['trigger']}{' ' + e['detail'] if e.get('detail') else ''} at {e['time']:.0f} s, "
                             f"{fmt(e.get('velocity_before'), scale=100)} -> {fmt(e.get('velocity_after'), scale=100)}"
                             for e in found) or "-"
            lines.append(f"| {robot} | {seed} | {len(walking)} | {len(found)} | {fmt(med(walking), scale=100)} "
                         f"({fmt(min(walking) if walking else None, scale=100)}-"
                         f"{fmt(max(walking) if walking else None, scale=100)}) | {what} |")
    return lines


PARTS = {"transform": part_transform, "latency": part_latency, "recall": part_recall,
         "false-alarm": part_false_alarm}


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[2:]))
    parser.add_argument("--parts", default=",".join(PARTS), help="comma-separated (default: all)")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--seed-list", dest="seed_list_text", default=None, metavar="LIST",
                        help="comma-separated world seeds to run instead of 1..--seeds (e.g. 4,5)")
    parser.add_argument("--daemons", type=int, default=daemons.default_daemons())
    parser.add_argument("--hosts", default=None, help="use running daemons instead (one life per daemon)")
    parser.add_argument("--out", default="results/lifelong-bench")
    parser.add_argument("--build", default="build/release")
    parser.add_argument("--online-budget", type=int, default=45)
    parser.add_argument("--model-budget", type=int, default=250)
    parser.add_argument("--offline-budget", type=int, default=1000)
    parser.add_argument("--offline-plugins", default="powell,cmaes",
                        help="plugins of the offline reference runs (the best counts)")
    parser.add_argument("--false-alarm-time", type=float, default=1800)
    parser.add_argument("--robots", default=",".join(ROBOTS), help="false-alarm: robots of configs/robots")
    parser.add_argument("--quick", action="store_true", help="tiny settings for tests")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    for part in args.parts.split(","):
        if part not in PARTS:
            parser.error(f"unknown part {part!r} (choose from {', '.join(PARTS)})")
    if args.quick:
        args.seeds, args.online_budget, args.model_budget, args.offline_budget = 1, 3, 4, 6
        args.false_alarm_time = 60
        args.short = ["--window-periods", "2", "--learn-windows", "2", "--settle-periods", "0.5",
                      "--trial-periods", "1.5", "--model-warmup", "1", "--model-duration", "2"]
    else:
        args.short = []
    for robot in args.robots.split(","):
        if robot not in ROBOTS:
            parser.error(f"unknown robot {robot!r} (choose from {', '.join(ROBOTS)})")
    if args.seeds < 1 or args.daemons < 1:
        parser.error("--seeds and --daemons must be at least 1")
    args.seed_list = list(range(1, args.seeds + 1))
    if args.seed_list_text is not None:
        try:
            args.seed_list = [int(s) for s in args.seed_list_text.split(",")]
        except ValueError:
            parser.error(f"--seed-list {args.seed_list_text!r} is not a comma-separated list of integers")
        if not args.seed_list or min(args.seed_list) < 1:
            parser.error("--seed-list needs seeds >= 1")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    bins = binaries(args.build)
    out = Path(args.out)
    if not out.is_absolute():
        out = Path.cwd() / out
    out.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("YAMOR_PYTHON", sys.executable)
    rows: list[dict] = []
    lines = ["## Lifelong learning benchmark", ""]
    started = time.monotonic()
    pool = (daemons.DaemonPool.existing(args.hosts) if args.hosts else
            daemons.DaemonPool.start(bins["yamord"], args.daemons, out / "daemons", workers=2, quiet=args.quiet))
    with pool:
        hosts = Hosts(pool.hosts)
        for part in args.parts.split(","):
            part_started = time.monotonic()
            lines += PARTS[part](args, bins, hosts, pool.hosts, out, rows)
            lines += ["", f"({part}: {time.monotonic() - part_started:.0f} s wall)", ""]
            if not args.quiet:
                print(f"lifelong_bench: {part} done", flush=True)
    lines.append(f"Total wall time {time.monotonic() - started:.0f} s with {len(pool.hosts)} daemon(s).")
    text = "\n".join(lines) + "\n"
    (out / "lifelong-bench.md").write_text(text)
    keys = sorted({k for r in rows for k in r})
    with open(out / "runs.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    print(text, end="")
    return 0


def cli() -> int:
    """The yamor-lifelong-bench command: main() with errors and Ctrl-C mapped to exit statuses."""
    return daemons.main_guard(main)


if __name__ == "__main__":
    sys.exit(cli())
