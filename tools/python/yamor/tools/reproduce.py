"""Reproduces the thesis's chapter 4, 6 and 7 figures (yamor-characterize, yamor-optimize, yamor-lifelong).

Usage: yamor-reproduce {ch4,fig6-3,fig6-5-7,fig6-12,fig7-4,fig7-5,all} [--out results/reproduce]
                       [--build build/release] [--quick] [--hosts H:P,...] [--daemons N]

  fig6-3    the 64x64 landscape of the quadruped's velocity over the hip->knee
            phase lag x the knee offset, the five other Table 6.1 parameters at
            a learned gait (configs/optimize/quadruped-2.xml), grid plugin
  fig6-5-7  classic Powell (Brent line search) on the same two parameters from
            the thesis's three start points, each path drawn on the landscape
            (runs fig6-3 first when its landscape is missing)
  fig6-12   classic vs interval Powell on the seven parameters (quadruped-7.xml)
            from 10 seeded random start points, best-so-far curves side by side
  all       the three, over one daemon pool
  fig7-4    the quadruped's velocity over its life, transformed at minute 4
            (configs/lifelong/transform.toml): yamor-lifelong on one daemon
            notices the change, rebuilds its CPG network and relearns
            (--mode online, the thesis's way, or model)
  fig7-5    the quadruped's recovery after a fall (configs/lifelong/table.toml):
            yamor-lifelong lives through the fall off a table and relearns; the
            story is then filmed on a daemon (frames drawn headless), the
            starting gait walking off the table and, once the robot lies on its
            back, the gait the life relearned: a strip of frames, the
            trajectory and its CSV
  ch4       chapter 4 in simulation (no daemons): Table 4.1 and Figures B.1-B.19
            from yamor-characterize noise and moves (seed --eval-seed), drawn by
            yamor-plot-characterize (not with --quick)

Every command writes its PNG and CSV under OUT/<figure>/ (see
tools/reproduce/README.md). Unless --hosts names running daemons, it starts
--daemons local yamord (one Evaluate worker each; default one per core) on
ephemeral ports and stops them at the end, also on errors and Ctrl-C.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from yamor.checkout import REPO
from yamor.tools import daemons
from yamor.tools.daemons import DaemonPool, ToolError

CONFIG_2 = REPO / "configs" / "optimize" / "quadruped-2.xml"
CONFIG_7 = REPO / "configs" / "optimize" / "quadruped-7.xml"
PHASE, OFFSET = "phase.0.5", "offset.5"
PHASE_LABEL = "phase lag inner → outer, phase.0.5 [rad]"
OFFSET_LABEL = "outer (knee) offset, offset.5 [rad]"
VELOCITY_LABEL = "velocity [cm/s]"
RUN_LETTERS = "abcdefghijklmnopqrstuvwxyz"

# Thesis Figures 6.5-6.7 give their start points as (phase lag; offset).
# (2; 0.5) lies outside the offset range [-pi/2, 0] of Table 6.1: it starts on
# the bound instead (README.md).
PATH_STARTS = [
    ("fig6-5", (0.0, -0.5), "(0; -0.5)", "direction set change after the first iteration"),
    ("fig6-6", (2.0, -1.5), "(2; -1.5)", "converges to a local maximum"),
    ("fig6-7", (2.0, 0.0), "(2; 0.5 → 0)",
     "starts in the opposite direction"),
]


@dataclass
class Settings:
    """What one invocation runs: timing, sizes and where things go."""

    out: Path
    bins: dict
    hosts: str
    quiet: bool
    no_plot: bool
    warmup: float
    duration: float
    eval_seed: int
    seed: int
    resolution: int
    path_budget: int
    budget: int
    starts: int
    landscape: Path | None


def optimize_args(s: Settings, plugin: str, config: Path, out: Path, sets: dict) -> list[str]:
    """yamor-optimize's arguments for one run (or batch) over the pool."""
    argv = ["--plugin", plugin, "--plugin-dir", str(s.bins["plugins"]), "--config", str(config),
            "--world", "quadruped", "--hosts", s.hosts, "--warmup", repr(s.warmup),
            "--duration", repr(s.duration), "--eval-seed", str(s.eval_seed), "--out", str(out),
            "--no-video"]  # the figures come from the CSVs; a video per run would double the CPU
    if s.no_plot:
        argv.append("--no-plot")  # progress.png costs a Python start per run
    for key, value in sets.items():
        argv += ["--set", f"{key}={value}"]
    return argv


def run(s: Settings, argv: list[str], log: Path) -> None:
    started = time.monotonic()
    daemons.run_optimize(s.bins["optimize"], argv, quiet=s.quiet, log=log)
    if not s.quiet:
        print(f"reproduce: run took {time.monotonic() - started:.0f} s", flush=True)


def read_rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_csv(path: Path, header: list[str], rows) -> int:
    """Writes header + rows (numbers with repr, so they read back exactly); returns the row count."""
    count = 0
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        for row in rows:
            writer.writerow([repr(c) if isinstance(c, float) else c for c in row])
            count += 1
    return count


def plot_landscape_module():
    from yamor.tools import plot_landscape  # matplotlib: imported only to draw

    return plot_landscape


def labelled_landscape(raw: Path, dest: Path) -> None:
    """The grid plugin's landscape (phase.0.5, offset.5, m/s) with axis labels and cm/s,
    so plot_landscape.py labels the figure like the thesis."""
    rows = read_rows(raw)
    write_csv(dest, [PHASE_LABEL, OFFSET_LABEL, VELOCITY_LABEL],
              ((float(r[PHASE]), float(r[OFFSET]), 100.0 * float(r["value"])) for r in rows))


def labelled_path(evaluations: Path, dest: Path) -> int:
    """A run's evaluations over (phase.0.5, offset.5) with the landscape's labels; returns the rows."""
    rows = read_rows(evaluations)
    return write_csv(dest, ["index", PHASE_LABEL, OFFSET_LABEL, VELOCITY_LABEL],
                     ((int(r["index"]), float(r[PHASE]), float(r[OFFSET]),
                       100.0 * float(r["velocity"])) for r in rows))


# --- Figure 6.3 -------------------------------------------------------------

def fig6_3(s: Settings) -> Path:
    """The landscape: grid plugin over (phase.0.5, offset.5); returns the raw landscape CSV."""
    out = s.out / "fig6-3"
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    raw = out / "landscape.csv"
    points = s.resolution ** 2
    print(f"reproduce: Figure 6.3, {s.resolution}x{s.resolution} = {points} evaluations of "
          f"{s.warmup:g} s + {s.duration:g} s", flush=True)
    # x = the first swept parameter (the phase lag), y = the second (the offset).
    run(s, optimize_args(s, "grid", CONFIG_2, out / "grid", {
        "parameters": f"{PHASE},{OFFSET}", "resolution": s.resolution, "max_evaluations": points,
        "landscape_csv": raw}), out / "yamor-optimize.log")
    if not raw.exists():
        raise ToolError(f"the grid run did not write {raw}")
    labelled = out / "fig6-3.csv"
    labelled_landscape(raw, labelled)
    png = out / "fig6-3.png"
    plot_landscape_module().draw(
        str(labelled), str(png), label=VELOCITY_LABEL,
        title=f"Figure 6.3: velocity over knee offset × hip→knee phase lag\n"
              f"({s.resolution}×{s.resolution} points, {s.warmup:g} s + {s.duration:g} s walk, "
              f"others at a learned gait)")
    print(f"reproduce: wrote {png} and {labelled}", flush=True)
    return raw


# --- Figures 6.5-6.7 --------------------------------------------------------

def toml_string(value: str) -> str:
    return json.dumps(value)  # a JSON string is a valid TOML basic string


def fig6_5_7(s: Settings) -> list[Path]:
    """Three Powell (Brent) paths on the landscape; returns the PNGs."""
    raw = s.landscape or (s.out / "fig6-3" / "landscape.csv")
    if not raw.exists():
        if s.landscape:
            raise ToolError(f"--landscape {raw} does not exist")
        print(f"reproduce: {raw} missing, computing Figure 6.3 first", flush=True)
        raw = fig6_3(s)
    out = s.out / "fig6-5-7"
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    batch = out / "batch.toml"
    lines = []
    for name, (phase, offset), _, _ in PATH_STARTS:
        lines += ["[[instance]]", f"name = {toml_string(name)}", f"seed = {s.seed}", "[instance.set]",
                  f"start = {toml_string(f'{phase!r},{offset!r}')}", ""]
    batch.write_text("\n".join(lines))
    print(f"reproduce: Figures 6.5-6.7, 3 classic Powell runs (brent) of at most {s.path_budget} "
          f"evaluations on {CONFIG_2.name}", flush=True)
    run(s, optimize_args(s, "powell", CONFIG_2, out / "runs", {
        "line_search": "brent", "bounds": "constant", "max_evaluations": s.path_budget})
        + ["--batch", str(batch), "--seed", str(s.seed)], out / "yamor-optimize.log")

    labelled = out / "landscape-labelled.csv"
    labelled_landscape(raw, labelled)
    plot = plot_landscape_module()
    pngs = []
    for name, _, start_text, caption in PATH_STARTS:
        evaluations = out / "runs" / name / "evaluations.csv"
        path_csv = out / f"{name}.csv"
        count = labelled_path(evaluations, path_csv)
        summary = json.loads((out / "runs" / name / "summary.json").read_text())
        best = summary["best"]["velocity"] * 100.0 if summary.get("best") else float("nan")
        png = out / f"{name}.png"
        number = name.replace("fig", "Figure ").replace("-", ".")
        plot.draw(str(labelled), str(png), path=str(path_csv), label=VELOCITY_LABEL,
                  title=f"{number}: classic Powell from {start_text}: {count} evaluations "
                        f"({summary['status']}), best {best:.2f} cm/s\nthesis: {caption}")
        pngs.append(png)
        print(f"reproduce: wrote {png} and {path_csv}", flush=True)
    return pngs


# --- Figure 6.12 ------------------------------------------------------------

def optimized_bounds(config: Path) -> list[tuple[str, float, float]]:
    """(name, min, max) of every <optimize> rule with bounds, in file order."""
    bounds = []
    for rule in ET.parse(config).getroot().iter("optimize"):
        if rule.get("min") is not None and rule.get("max") is not None:
            bounds.append((rule.get("param"), float(rule.get("min")), float(rule.get("max"))))
    if not bounds:
        raise ToolError(f"{config}: no <optimize param min max> rule")
    return bounds


def random_starts(bounds, count: int, seed: int) -> list[list[float]]:
    """`count` points uniform inside the bounds from a seeded generator (the same for both methods)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    return [[float(lo + (hi - lo) * rng.random()) for _, lo, hi in bounds] for _ in range(count)]


def best_so_far(values: list[float]) -> list[float]:
    best, out = -math.inf, []
    for v in values:
        best = max(best, v)
        out.append(best)
    return out


def fig6_12(s: Settings) -> Path:
    """Classic vs interval Powell from the same random starts; returns the PNG."""
    out = s.out / "fig6-12"
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    bounds = optimized_bounds(CONFIG_7)
    starts = random_starts(bounds, s.starts, s.seed)
    letters = RUN_LETTERS[:s.starts]
    write_csv(out / "starts.csv", ["run", *(name for name, _, _ in bounds)],
              ([letter, *point] for letter, point in zip(letters, starts)))
    methods = [("classic", "brent"), ("interval", "interval")]
    lines = []
    for method, line_search in methods:
        for i, (letter, point) in enumerate(zip(letters, starts)):
            lines += ["[[instance]]", f"name = {toml_string(f'{method}-{letter}')}",
                      f"seed = {s.seed + i}", "[instance.set]",
                      f"line_search = {toml_string(line_search)}",
                      f"start = {toml_string(','.join(repr(v) for v in point))}", ""]
    batch = out / "batch.toml"
    batch.write_text("\n".join(lines))
    runs = len(methods) * s.starts
    print(f"reproduce: Figure 6.12, {runs} Powell runs (classic and interval from {s.starts} starts) "
          f"of at most {s.budget} evaluations on {CONFIG_7.name}", flush=True)
    run(s, optimize_args(s, "powell", CONFIG_7, out / "runs",
                         {"bounds": "constant", "max_evaluations": s.budget})
        + ["--batch", str(batch)], out / "yamor-optimize.log")

    curves = {}
    rows = []
    for method, _ in methods:
        for letter in letters:
            evaluations = read_rows(out / "runs" / f"{method}-{letter}" / "evaluations.csv")
            velocities = [100.0 * float(r["velocity"]) for r in evaluations]
            best = best_so_far(velocities)
            curves[(method, letter)] = best
            rows += [(method, letter, n + 1, v, b) for n, (v, b) in enumerate(zip(velocities, best))]
    curves_csv = out / "curves.csv"
    write_csv(curves_csv, ["method", "run", "evaluation", "velocity_cm_s", "best_cm_s"], rows)
    png = out / "fig6-12.png"
    draw_fig6_12(curves, letters, png, s)
    write_csv(out / "final.csv", ["run", "classic_best_cm_s", "interval_best_cm_s",
                                  "classic_evaluations", "interval_evaluations"],
              ((letter, curves[("classic", letter)][-1] if curves[("classic", letter)] else 0.0,
                curves[("interval", letter)][-1] if curves[("interval", letter)] else 0.0,
                len(curves[("classic", letter)]), len(curves[("interval", letter)]))
               for letter in letters))
    print(f"reproduce: wrote {png}, {curves_csv}, {out / 'final.csv'}", flush=True)
    return png


def draw_fig6_12(curves, letters, png: Path, s: Settings) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5), dpi=100, sharey=True)
    panels = [("classic", "Classic Powell (Brent line search)", plt.cm.Blues),
              ("interval", "Powell with interval line search (6.2.5)", plt.cm.Reds)]
    span = max((max(c) for c in curves.values() if c), default=1.0)
    for ax, (method, title, cmap) in zip(axes, panels):
        placed = []  # (x end, label y) of the labels drawn, to keep them apart
        for i, letter in enumerate(letters):
            curve = curves[(method, letter)]
            if not curve:
                continue
            color = cmap(0.35 + 0.6 * i / max(1, len(letters) - 1))
            ax.plot(range(1, len(curve) + 1), curve, color=color, linewidth=1.4)
            # Runs that end at about the same point and value get stacked labels.
            y = curve[-1]
            while any(abs(len(curve) - x) < 0.08 * s.budget and abs(y - py) < 0.03 * span
                      for x, py in placed):
                y += 0.03 * span
            placed.append((len(curve), y))
            ax.annotate(letter, (len(curve), y), textcoords="offset points", xytext=(3, 0),
                        fontsize=8, color=color, va="center")
        ax.set_title(title)
        ax.set_xlabel("evaluation")
        ax.set_xlim(0, s.budget * 1.06)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("best velocity so far [cm/s]")
    fig.suptitle(f"Figure 6.12: {len(letters)} runs from the same random starts (seed {s.seed}), "
                 f"7 parameters, {s.budget} evaluations each, {s.duration:g} s walk")
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)


# --- command line -------------------------------------------------------------

def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[4:]))
    parser.add_argument("figure", choices=["ch4", "fig6-3", "fig6-5-7", "fig6-12", "fig7-4", "fig7-5", "all"])
    parser.add_argument("--out", default="results/reproduce", help="results folder (default %(default)s)")
    parser.add_argument("--build", default="build/release", help="build tree (default %(default)s)")
    parser.add_argument("--quick", action="store_true",
                        help="tiny settings for tests: resolution 4, budgets 10, 1 s + 2 s, "
                             "no progress.png per run")
    parser.add_argument("--hosts", default=None, help="use these running daemons (H:P,H:P or @FILE)")
    parser.add_argument("--daemons", type=int, default=daemons.default_daemons(),
                        help="local daemons to start, one worker each (default: cores = %(default)s)")
    parser.add_argument("--warmup", type=float, default=None, help="seconds before the measured span (8)")
    parser.add_argument("--duration", type=float, default=None, help="measured span [s] (12)")
    parser.add_argument("--eval-seed", type=int, default=0, help="simulation seed (default 0)")
    parser.add_argument("--seed", type=int, default=1,
                        help="Powell's seed and the seed of Figure 6.12's start points (default 1)")
    parser.add_argument("--resolution", type=int, default=None, help="landscape points per axis (64)")
    parser.add_argument("--path-budget", type=int, default=None,
                        help="evaluations per Powell run of Figures 6.5-6.7 (200)")
    parser.add_argument("--budget", type=int, default=None,
                        help="evaluations per run of Figure 6.12 (300); fig7-4, fig7-5: relearning trials "
                             "(default: the scenario's)")
    parser.add_argument("--mode", choices=["online", "model"], default="online",
                        help="fig7-4, fig7-5: how yamor-lifelong relearns (default %(default)s)")
    parser.add_argument("--starts", type=int, default=10, help="start points of Figure 6.12 (10)")
    parser.add_argument("--landscape", default=None,
                        help="fig6-5-7: draw on this landscape CSV instead of OUT/fig6-3/landscape.csv")
    parser.add_argument("--quiet", action="store_true", help="yamor-optimize's output to log files only")
    args = parser.parse_args(argv)
    quick = args.quick
    args.budget_set = args.budget is not None
    defaults = {"warmup": (1.0, 8.0), "duration": (2.0, 12.0), "resolution": (4, 64),
                "path_budget": (10, 200), "budget": (10, 300)}
    for name, (small, full) in defaults.items():
        if getattr(args, name) is None:
            setattr(args, name, small if quick else full)
    if args.resolution < 2:
        parser.error("--resolution must be at least 2")
    if args.budget < 1 or args.path_budget < 1:
        parser.error("budgets must be at least 1")
    if not 1 <= args.starts <= len(RUN_LETTERS):
        parser.error(f"--starts must be within 1..{len(RUN_LETTERS)}")
    if args.daemons < 1:
        parser.error("--daemons must be at least 1")
    return args


# --- Chapter 4 ----------------------------------------------------------------

def ch4(args, out: Path) -> Path:
    """Table 4.1 and appendix B's figures; returns the results folder."""
    build = Path(args.build)
    if not build.is_absolute():
        build = REPO / build
    tool = build / "tools" / "characterize" / "yamor-characterize"
    if not tool.exists():
        raise ToolError(f"{tool} does not exist (build the yamor-characterize target, or pass --build)")
    folder = out / "ch4"
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    seed = str(args.eval_seed)
    for command in (["noise"], ["moves"]):
        argv = [str(tool), *command, "--out", str(folder), "--seed", seed]
        print("reproduce: " + " ".join(argv), flush=True)
        result = subprocess.run(argv, capture_output=True, text=True)
        (folder / f"{command[0]}.log").write_text(result.stdout + result.stderr)
        if result.returncode != 0:
            raise ToolError(f"{' '.join(argv)} failed ({result.returncode}): {result.stderr.strip()}")
        if not args.quiet:
            print(result.stdout, end="", flush=True)
    if not args.quick:
        from yamor.tools import plot_characterize

        if plot_characterize.main([str(folder)]) != 0:
            raise ToolError(f"plot_characterize.py could not draw {folder}")
    return folder


# --- Chapter 7 ----------------------------------------------------------------

LIFELONG_SCENARIO = REPO / "configs" / "lifelong" / "transform.toml"


def fig7_4(args, out: Path) -> Path:
    """Figure 7.4: one life of the quadruped through the 7.5.1 transformation; returns the folder."""
    build = Path(args.build)
    if not build.is_absolute():
        build = REPO / build
    tool = build / "optimizer-plugins" / "lifelong" / "yamor-lifelong"
    if not tool.exists():
        raise ToolError(f"{tool} does not exist (build the yamor-lifelong target, or pass --build)")
    folder = out / "fig7-4"
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    scenario = LIFELONG_SCENARIO
    extra = []
    if args.quick:
        # The same story in a minute of robot time: the change at 20 s, short
        # windows, three relearning trials.
        text = scenario.read_text()
        text = text.replace('config = "quadruped-walking.xml"',
                            f'config = "{scenario.parent / "quadruped-walking.xml"}"')
        text = text.replace('file = "../scripts/', f'file = "{REPO / "configs" / "scripts"}/')
        text = text.replace("at = 240", "at = 20")
        scenario = folder / "quick.toml"
        scenario.write_text(text)
        extra = ["--max-time", "90", "--window-periods", "2", "--settle-periods", "0.5",
                 "--trial-periods", "1.5", "--set", "max_evaluations=3"]
    elif args.budget_set:
        extra = ["--set", f"max_evaluations={args.budget}"]
    workers = 2 if args.mode == "model" else 1
    with (daemons.DaemonPool.existing(args.hosts) if args.hosts
          else daemons.DaemonPool.start(daemons.binaries(args.build)["yamord"], 1, folder / "daemons",
                                        workers=workers, quiet=args.quiet)) as pool:
        life = folder / "life"
        argv = [str(tool), "--host", pool.hosts[0], "--scenario", str(scenario), "--out", str(life),
                "--mode", args.mode, "--seed", str(args.seed), *extra]
        if args.quiet:
            argv += ["--quiet", "--log-level", "warn"]
        print("reproduce: " + " ".join(argv), flush=True)
        log = folder / "yamor-lifelong.log"
        # timeline.png is drawn with this interpreter (the one with matplotlib).
        env = dict(os.environ)
        env.setdefault("YAMOR_PYTHON", sys.executable)
        with open(log, "w") as f:
            result = subprocess.run(argv, cwd=REPO, stdout=f, stderr=subprocess.STDOUT if args.quiet else None,
                                    env=env)
        if result.returncode != 0:
            raise ToolError(f"yamor-lifelong exited with status {result.returncode}; see {log}")
    for name, dest in (("timeline.csv", "fig7-4.csv"), ("timeline.png", "fig7-4.png")):
        if not (life / name).exists():
            raise ToolError(f"{life / name} was not written (matplotlib missing?); see {log}")
        shutil.copy(life / name, folder / dest)
    return folder


TABLE_SCENARIO = REPO / "configs" / "lifelong" / "table.toml"
TABLE_WORLD = REPO / "configs" / "lifelong" / "quadruped-extended-table.xml"
WALKING_GAIT = REPO / "configs" / "lifelong" / "quadruped-walking.xml"


def robot_xml(problem_xml: str) -> str:
    """The robot configuration of an optimization configuration (its rules left out)."""
    root = ET.fromstring(problem_xml)
    for tag in ("optimize", "constrain"):
        for element in root.findall(tag):
            root.remove(element)
    return ET.tostring(root, encoding="unicode")


def relearned_gait(db: Path) -> tuple[int, str]:
    """The id and robot configuration of the last gait stored for walking upside down."""
    import sqlite3

    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as connection:
        row = connection.execute(
            "SELECT id, config_xml FROM gaits WHERE orientation = 'upside_down' ORDER BY id DESC LIMIT 1"
        ).fetchone()
    if row is None:
        raise ToolError(f"{db} holds no gait for walking upside down: the life did not relearn")
    return int(row[0]), row[1]


def film_recovery(host: str, seed: int, gait_xml: str, folder: Path, quick: bool) -> list[dict]:
    """Replays the fall and the recovery on `host` for the camera; returns the frames shot."""
    import yamor

    step = 0.5
    walk_after_landing = 12.0 if quick else 40.0
    shots: list[dict] = []
    trajectory: list[tuple[float, float, float, float, str]] = []
    with yamor.Host(host, timeout=60) as h:
        h.open_simulation(morphology_file=TABLE_WORLD, seed=seed)
        h.load_config(robot_xml(WALKING_GAIT.read_text()), "quadruped-walking.xml")
        h.connect()
        h.control(uart=True, cpg=True, motors=True)
        table_top = 0.4

        def shoot(label: str) -> None:
            t = h.elapsed_time()
            png = folder / f"frame-{len(shots) + 1:02d}.png"
            # From the +y side: the robot walks off the table's +y edge towards the camera.
            h.snapshot(png, camera="follow", distance=1.3, elevation=0.45, azimuth=1.2,
                       width=480, height=360, labels=False, legend=False)
            shots.append({"file": png.name, "time": t, "label": label})

        def sample(phase: str) -> None:
            p = h.simulated_position().xyz
            trajectory.append((h.elapsed_time(), p[0], p[1], p[2], phase))

        shoot("on the table")
        landed_at = None
        next_shot = 6.0
        while h.elapsed_time() < 120.0:
            h.sleep(step)
            sample("starting gait")
            t, z = trajectory[-1][0], trajectory[-1][3]
            if landed_at is None and z < table_top - 0.2:
                landed_at = t
                h.sleep(2.0)  # at rest on the floor
                sample("starting gait")
                shoot("fallen, on its back")
                break
            if t >= next_shot:
                shoot("walking on the table")
                next_shot += 6.0
        if landed_at is None:
            raise ToolError("the robot did not walk off the table within 120 s")
        # The relearned gait takes over, as the life's did.
        h.load_config(gait_xml, "relearned gait")
        h.refresh()
        start = h.elapsed_time()
        next_shot = start + walk_after_landing / 3
        while h.elapsed_time() < start + walk_after_landing:
            h.sleep(step)
            sample("relearned gait")
            if h.elapsed_time() >= next_shot - 1e-9:
                shoot("walking on its back")
                next_shot += walk_after_landing / 3
    write_csv(folder / "fig7-5-trajectory.csv", ["time", "x", "y", "z", "gait"], trajectory)
    return shots


def draw_fig7_5(folder: Path, shots: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    columns = 4
    rows = (len(shots) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.6 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, shot in zip(axes.flat, shots):
        ax.imshow(mpimg.imread(folder / shot["file"]))
        ax.set_title(f"{shot['time']:.0f} s: {shot['label']}", fontsize=9)
    fig.suptitle("Figure 7.5: quadruped recovery after a fall (off a 40 cm table)")
    fig.tight_layout()
    fig.savefig(folder / "fig7-5.png", dpi=100)
    plt.close(fig)

    rows_csv = read_rows(folder / "fig7-5-trajectory.csv")
    fig, (top, side) = plt.subplots(1, 2, figsize=(11, 4))
    for gait, colour in (("starting gait", "tab:blue"), ("relearned gait", "tab:red")):
        part = [r for r in rows_csv if r["gait"] == gait]
        top.plot([float(r["x"]) for r in part], [float(r["y"]) for r in part], color=colour, label=gait)
        side.plot([float(r["time"]) for r in part], [float(r["z"]) for r in part], color=colour, label=gait)
    for box in ET.parse(TABLE_WORLD).getroot().findall("box"):  # the tables, seen from above
        sx, sy, _ = (float(v) for v in box.get("size").split())
        px, py, _ = (float(v) for v in box.get("position", "0 0 0").split())
        top.add_patch(plt.Rectangle((px - sx / 2, py - sy / 2), sx, sy, fill=False, hatch="//", color="grey",
                                    label=box.get("name", "table")))
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.legend(fontsize=8)
    side.set_xlabel("time [s]")
    side.set_ylabel("height of the central module [m]")
    side.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(folder / "fig7-5-trajectory.png", dpi=100)
    plt.close(fig)


def fig7_5(args, out: Path) -> Path:
    """Figure 7.5: the fall off the table, lived by yamor-lifelong, then filmed; returns the folder."""
    build = Path(args.build)
    if not build.is_absolute():
        build = REPO / build
    tool = build / "optimizer-plugins" / "lifelong" / "yamor-lifelong"
    if not tool.exists():
        raise ToolError(f"{tool} does not exist (build the yamor-lifelong target, or pass --build)")
    folder = out / "fig7-5"
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    extra = ["--max-anomalies", "1"]
    if args.quick:
        extra += ["--window-periods", "2", "--settle-periods", "0.5", "--trial-periods", "1.5",
                  "--set", "max_evaluations=3"]
    elif args.budget_set:
        extra += ["--set", f"max_evaluations={args.budget}"]
    workers = 2 if args.mode == "model" else 1
    with (daemons.DaemonPool.existing(args.hosts) if args.hosts
          else daemons.DaemonPool.start(daemons.binaries(args.build)["yamord"], 1, folder / "daemons",
                                        workers=workers, quiet=args.quiet)) as pool:
        life = folder / "life"
        argv = [str(tool), "--host", pool.hosts[0], "--scenario", str(TABLE_SCENARIO), "--out", str(life),
                "--mode", args.mode, "--seed", str(args.seed), *extra]
        if args.quiet:
            argv += ["--quiet", "--log-level", "warn"]
        print("reproduce: " + " ".join(argv), flush=True)
        log = folder / "yamor-lifelong.log"
        env = dict(os.environ)
        env.setdefault("YAMOR_PYTHON", sys.executable)
        with open(log, "w") as f:
            result = subprocess.run(argv, cwd=REPO, stdout=f, stderr=subprocess.STDOUT if args.quiet else None,
                                    env=env)
        if result.returncode != 0:
            raise ToolError(f"yamor-lifelong exited with status {result.returncode}; see {log}")
        gait_id, gait_xml = relearned_gait(life / "gaits.sqlite")
        print(f"reproduce: filming the fall and gait {gait_id} on {pool.hosts[0]}", flush=True)
        shots = film_recovery(pool.hosts[0], 1, gait_xml, folder, args.quick)
    write_csv(folder / "fig7-5-frames.csv", ["file", "time", "label"],
              [(s["file"], f"{s['time']:.3f}", s["label"]) for s in shots])
    draw_fig7_5(folder, shots)
    for name, dest in (("timeline.csv", "fig7-5-timeline.csv"), ("timeline.png", "fig7-5-timeline.png")):
        if (life / name).exists():
            shutil.copy(life / name, folder / dest)
    return folder


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.figure == "fig7-5":
        out = Path(args.out)
        if not out.is_absolute():
            out = Path.cwd() / out
        started = time.monotonic()
        folder = fig7_5(args, out)
        print(f"reproduce: fig7-5 done in {time.monotonic() - started:.0f} s; results in {folder}", flush=True)
        return 0
    if args.figure == "fig7-4":
        out = Path(args.out)
        if not out.is_absolute():
            out = Path.cwd() / out
        started = time.monotonic()
        folder = fig7_4(args, out)
        print(f"reproduce: fig7-4 done in {time.monotonic() - started:.0f} s; results in {folder}", flush=True)
        return 0
    if args.figure == "ch4":
        out = Path(args.out)
        if not out.is_absolute():
            out = Path.cwd() / out
        started = time.monotonic()
        folder = ch4(args, out)
        print(f"reproduce: ch4 done in {time.monotonic() - started:.0f} s; results in {folder}",
              flush=True)
        return 0
    bins = daemons.binaries(args.build)
    out = Path(args.out)
    if not out.is_absolute():
        out = Path.cwd() / out
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    with daemons.open_pool(args, bins, out / "daemons") as pool:
        s = Settings(out=out, bins=bins, hosts=pool.hosts_arg(), quiet=args.quiet, no_plot=args.quick,
                     warmup=args.warmup, duration=args.duration, eval_seed=args.eval_seed,
                     seed=args.seed, resolution=args.resolution, path_budget=args.path_budget,
                     budget=args.budget, starts=args.starts,
                     landscape=Path(args.landscape).resolve() if args.landscape else None)
        if args.figure in ("fig6-3", "all"):
            fig6_3(s)
        if args.figure in ("fig6-5-7", "all"):
            fig6_5_7(s)
        if args.figure in ("fig6-12", "all"):
            fig6_12(s)
    print(f"reproduce: {args.figure} done in {time.monotonic() - started:.0f} s; results in {out}",
          flush=True)
    return 0


def cli() -> int:
    """The yamor-reproduce command: main() with errors and Ctrl-C mapped to exit statuses."""
    return daemons.main_guard(main)


if __name__ == "__main__":
    sys.exit(cli())
