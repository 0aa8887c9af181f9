"""Generated-problem benchmark: learning on yamor-cpg-build's problems (issue 12 section 8).

Usage: yamor-generated-bench [--seeds 3] [--robot-seeds 3] [--budget 300] [--robots NAME,...]
                             [--quick] [--hosts H:P,...] [--daemons N] [--out results/generated-bench]
                             [--warmup 8] [--duration 12] [--timing-runs 5] [--build build/release]

Learning runs use the learning benchmark's best variant (docs/benchmarks.md,
"Learning (issue 6)": powell-brent-stadium, `powell line_search=brent
bounds=stadium`), budget --budget evaluations, warm-up --warmup s + --duration s.

(a) The quadruped: the problem `yamor-cpg-build --world quadruped` generates
    against the hand-made configs/optimize/quadruped-7.xml (thesis Table 6.1),
    --seeds seeds each; median best velocity of each and their ratio (issue
    target: generated within 10 % of hand-made).
(b) Every appendix-A robot (snake, tripod, dog, trebuchet, wheel) and the
    transformed quadruped of thesis 7.5.1 (configs/scripts/quadruped-transform.xml
    applied to the quadruped, warm-started from configs/robots/quadruped.xml with
    --base): the configured gait's velocity (one evaluation of
    configs/robots/<name>.xml on the body, the evaluation seed the runs use)
    against the median best after the budget on the generated problem,
    --robot-seeds seeds. "Learns a faster gait" = best > configured. The
    generated problem's own start point (the run's evaluation 0) is shown too:
    it is not always the configured gait (the generated network and bounds
    can differ). Every configured gait and every run's best.xml are also
    re-evaluated at evaluation seeds --check-seeds (default 1,2,3) so that a
    gain tuned to the one evaluation seed of the runs shows up.
(c) The wall time of each robot's yamor-cpg-build command (median of
    --timing-runs runs).

The transformed body: a pool daemon opens the quadruped, runs the script
(RunTransformationScript) and is asked for its morphology (GetMorphology).
If that returns the body from before the script, the bench says so and builds
the morphology by applying the script's disconnect/connect steps to the
quadruped's morphology file itself (disconnect drops every connection of the
module; connect adds one). Either way it is written to
OUT/problems/quadruped-transformed.morphology.xml and optimized with
yamor-optimize --morphology.

Each problem's seeds run at once (one --batch) so the sequential Brent Powell
fills the pool; wall times are those of a run sharing the pool. With
--robot-seeds 1 the robots of (b) run side by side instead, one daemon each.
--reuse reads a problem's finished runs from OUT/runs/ instead of running it
again (to resume an interrupted benchmark); the table says which were reused. The tables
(Markdown) are printed and written to OUT/generated-bench.md, the per-run
numbers to OUT/runs.csv, the single evaluations to OUT/evaluations.csv, the
yamor-cpg-build timings to OUT/cpg-build-times.csv, the generated problems
(and --explain output) to OUT/problems/ and every run's results folder to
OUT/runs/<problem>/seed-<n>/.
"""

from __future__ import annotations

import argparse
import csv
import json
import queue
import statistics
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from yamor.checkout import REPO
from yamor.tools import daemons
from yamor.tools import learning_bench as lb
from yamor.tools.daemons import ToolError

VARIANT = lb.BY_NAME["powell-brent-stadium"]  # the learning benchmark's best (docs/benchmarks.md)
HAND_MADE = REPO / "configs" / "optimize" / "quadruped-7.xml"
TRANSFORM_SCRIPT = REPO / "configs" / "scripts" / "quadruped-transform.xml"
QUADRUPED_ROBOT = REPO / "configs" / "robots" / "quadruped.xml"
QUADRUPED_WORLD = REPO / "configs" / "worlds" / "quadruped.xml"
APPENDIX_A = ["snake", "tripod", "dog", "trebuchet", "wheel"]
TRANSFORMED = "quadruped-transformed"
ROBOTS = APPENDIX_A + [TRANSFORMED]
EVAL_SEED = 0  # yamor-optimize's --eval-seed default: every evaluation of a run uses it


@dataclass
class Problem:
    """One optimization problem: its configuration and the body it is evaluated on."""

    name: str
    robot: str  # quadruped, snake, ..., quadruped-transformed
    source: str  # "generated" or "hand-made"
    config: Path
    world: str | None = None  # built-in world, or
    morphology: Path | None = None  # a morphology file
    configured: Path | None = None  # the robot's own configuration (configs/robots/<name>.xml)
    free: int | None = None
    error: str = ""
    warnings: list[str] = field(default_factory=list)
    reused: bool = False  # --reuse: the runs were read from an earlier invocation's folders

    def body_argv(self) -> list[str]:
        """--world NAME or --morphology FILE, as yamor-optimize and yamorctl evaluate take them."""
        return ["--world", self.world] if self.world else ["--morphology", str(self.morphology)]


@dataclass
class Run:
    """One learning run (velocities in m/s); `start` is the run's evaluation 0."""

    problem: str
    seed: int
    result: lb.RunResult
    start: float | None


def tool_paths(build: str) -> dict[str, Path]:
    """daemons.binaries plus yamor-cpg-build and yamorctl; ToolError names a missing one."""
    bins = daemons.binaries(build)
    build_dir = bins["yamord"].parent.parent
    extra = {"cpg_build": build_dir / "tools" / "cpg_build" / "yamor-cpg-build",
             "yamorctl": build_dir / "tools" / "yamorctl" / "yamorctl"}
    for path in extra.values():
        if not path.exists():
            raise ToolError(f"{path} does not exist (build {build_dir} first, or pass --build)")
    return {**bins, **extra}


def run_command(argv: list[str], what: str, timeout: float = 300.0) -> subprocess.CompletedProcess:
    """Runs a command from the repository; ToolError with its stderr when it fails."""
    proc = subprocess.run([str(a) for a in argv], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        message = (proc.stderr.strip() or proc.stdout.strip()).splitlines()
        raise ToolError(f"{what}: exit {proc.returncode}: {message[-1] if message else ''}")
    return proc


def yamorctl(bins, host: str, *args: str, timeout: float = 300.0) -> subprocess.CompletedProcess:
    return run_command([bins["yamorctl"], "--host", host, *args], f"yamorctl {args[0]} on {host}",
                       timeout=timeout)


# --- the transformed quadruped -------------------------------------------------------------

def connections(morphology_xml: str) -> set[tuple]:
    root = ET.fromstring(morphology_xml)
    return {tuple(sorted(c.attrib.items())) for c in root.iter("connect")}


def apply_script(morphology_xml: str, script: Path) -> str:
    """The morphology after the script's <disconnect id> and <connect ...> steps (pauses ignored).

    A disconnect drops every connection of that module (each module the
    quadruped script moves is a leaf: its only connection is to its parent).
    """
    root = ET.fromstring(morphology_xml)
    for step in ET.parse(script).getroot():
        if step.tag == "disconnect":
            module = step.get("id")
            for c in [c for c in root.findall("connect") if module in (c.get("idfrom"), c.get("idto"))]:
                root.remove(c)
        elif step.tag == "connect":
            new = ET.SubElement(root, "connect", {k: step.get(k) for k in
                                                 ("idfrom", "connfrom", "idto", "connto", "angle")})
            new.tail = "\n"
        elif step.tag != "pause":
            raise ToolError(f"{script}: step <{step.tag}> not understood")
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n"


def transformed_morphology(bins, host: str, out: Path, notes: list[str]) -> Path:
    """Writes the transformed quadruped's morphology (from the daemon when it reports it) and returns its path."""
    yamorctl(bins, host, "open", "--world", "quadruped")
    before = yamorctl(bins, host, "morphology").stdout
    yamorctl(bins, host, "script", str(TRANSFORM_SCRIPT))
    after = yamorctl(bins, host, "morphology").stdout
    by_hand = apply_script(QUADRUPED_WORLD.read_text(), TRANSFORM_SCRIPT)
    path = out / f"{TRANSFORMED}.morphology.xml"
    if connections(after) == connections(before):
        notes.append("GetMorphology after RunTransformationScript (configs/scripts/quadruped-transform.xml) "
                     "returned the quadruped's body from before the script (same connections), so "
                     "`yamor-cpg-build --daemon` would see the old body too; the transformed morphology "
                     "was built from the script by hand (disconnect 7, 8; connect 7.front-5.rear, "
                     "8.front-6.rear, angle 0).")
        path.write_text(by_hand)
    else:
        agree = connections(after) == connections(by_hand)
        notes.append("Transformed morphology taken from the daemon (GetMorphology after "
                     "RunTransformationScript); " + ("it matches the script applied by hand." if agree else
                                                     "it DIFFERS from the script applied by hand."))
        path.write_text(after)
    yamorctl(bins, host, "open", "--world", "quadruped")  # leave the daemon as it was opened
    return path


# --- problems, timings, single evaluations ---------------------------------------------------

def cpg_build_argv(bins, problem: Problem, out: Path) -> list:
    argv = [bins["cpg_build"]]
    if problem.world:
        argv += ["--world", problem.world]
    else:
        argv += ["--morphology", problem.morphology, "--base", QUADRUPED_ROBOT]
    return argv + ["-o", out]


def generate(bins, problem: Problem, runs: int, problems_dir: Path) -> list[float]:
    """Writes the generated problem (timed `runs` times) and its --explain text; the wall times [s]."""
    times, outputs = [], set()
    for _ in range(runs):
        started = time.perf_counter()
        run_command(cpg_build_argv(bins, problem, problem.config), f"yamor-cpg-build ({problem.robot})")
        times.append(time.perf_counter() - started)
        outputs.add(problem.config.read_bytes())
    if len(outputs) != 1:
        problem.warnings.append(f"yamor-cpg-build wrote {len(outputs)} different files in {runs} runs")
    explain = run_command(cpg_build_argv(bins, problem, problems_dir / f"{problem.name}.check.xml")
                          + ["--explain"], f"yamor-cpg-build --explain ({problem.robot})")
    (problems_dir / f"{problem.name}.explain.txt").write_text(explain.stdout + explain.stderr)
    return times


def free_parameters(config: Path) -> int:
    return len(ET.parse(config).getroot().findall("optimize"))


def evaluate(bins, host: str, body: list[str], config: Path, args, seed: int) -> float:
    reply = yamorctl(bins, host, "--json", "evaluate", *body, "--config", str(config),
                     "--warmup", repr(args.warmup), "--duration", repr(args.duration), "--seed", str(seed))
    result = json.loads(reply.stdout)
    if result.get("diverged"):
        raise ToolError(f"evaluation of {config} diverged: {result.get('divergence', '')}")
    return float(result.get("velocity", 0.0))


def evaluate_all(bins, hosts: list[str], jobs: list[tuple]) -> list[float | str]:
    """Runs (key, body, config, args, seed) jobs on the hosts, one at a time per host; errors as text."""
    def one(i_job):
        i, (_, body, config, args, seed) = i_job
        try:
            return evaluate(bins, hosts[i % len(hosts)], body, config, args, seed)
        except (ToolError, subprocess.TimeoutExpired, ValueError) as error:
            return f"error: {error}"

    with ThreadPoolExecutor(max_workers=len(hosts)) as pool:
        return list(pool.map(one, enumerate(jobs)))


# --- learning runs ------------------------------------------------------------------------------

def optimize_argv(problem: Problem, args, bins, hosts: str, out: Path) -> list[str]:
    argv = ["--plugin", VARIANT.plugin, "--plugin-dir", str(bins["plugins"]), "--config", str(problem.config),
            *problem.body_argv(), "--hosts", hosts, "--warmup", repr(args.warmup),
            "--duration", repr(args.duration), "--eval-seed", str(EVAL_SEED), "--no-plot", "--no-video",
            "--set", f"max_evaluations={args.budget}", "--out", str(out)]
    for key, value in VARIANT.sets:
        argv += ["--set", f"{key}={value}"]
    return argv


def start_velocity(evaluations_csv: Path) -> float | None:
    with open(evaluations_csv, newline="") as f:
        for row in csv.DictReader(f):
            if row["index"] == "0":
                return float(row["velocity"])
    return None


def run_problem(problem: Problem, seeds: list[int], args, bins, hosts: str, out: Path) -> list[Run]:
    """All seeds of one problem in one --batch; the optimizer's warnings go to problem.warnings."""
    problem_dir = out / "runs" / problem.name
    problem_dir.mkdir(parents=True, exist_ok=True)
    if args.reuse and all(finished(problem, seed, args, problem_dir / f"seed-{seed}") for seed in seeds):
        problem.reused = True
        collect_warnings(problem, problem_dir / "yamor-optimize.log")
        return read_runs(problem, seeds, problem_dir)
    batch = problem_dir / "batch.toml"
    batch.write_text("".join(f'[[instance]]\nname = "seed-{seed}"\nseed = {seed}\n\n' for seed in seeds))
    log = problem_dir / "yamor-optimize.log"
    try:
        daemons.run_optimize(bins["optimize"], optimize_argv(problem, args, bins, hosts, problem_dir)
                             + ["--batch", str(batch)], quiet=True, log=log)
    finally:
        collect_warnings(problem, log)
    return read_runs(problem, seeds, problem_dir)


def collect_warnings(problem: Problem, log: Path) -> None:
    """The optimizer's warning and error lines (once each) into problem.warnings."""
    if not log.exists():
        return
    for line in log.read_text().splitlines():
        if " warning " in line or " error " in line:
            text = line.split("] ", 1)[-1]
            if text not in problem.warnings:
                problem.warnings.append(text)


def finished(problem: Problem, seed: int, args, run_dir: Path) -> bool:
    """--reuse: run_dir holds a finished run of this problem, seed, variant and budget."""
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    fields = summary.get("fields", {})
    return (summary.get("status") in ("budget", "converged") and summary.get("seed") == seed
            and Path(summary.get("problem", "")) == problem.config
            and fields.get("max_evaluations") == str(args.budget)
            and all(fields.get(k) == v for k, v in VARIANT.sets))


def read_runs(problem: Problem, seeds: list[int], problem_dir: Path) -> list[Run]:
    runs = []
    for seed in seeds:
        run_dir = problem_dir / f"seed-{seed}"
        result = lb.read_run(lb.Variant(problem.name, VARIANT.plugin, VARIANT.sets), seed, run_dir)
        runs.append(Run(problem.name, seed, result, start_velocity(run_dir / "evaluations.csv")))
    return runs


# --- tables ----------------------------------------------------------------------------------

def median(values: list[float | None]) -> float | None:
    values = [v for v in values if isinstance(v, float)]
    return statistics.median(values) if values else None


def best(run: Run) -> float | None:
    return run.result.best_so_far[-1] if run.result.best_so_far else None


def quadruped_table(problems: list[Problem], runs: list[Run], args) -> tuple[str, str]:
    header = (["problem", "configuration", "free parameters", "start [cm/s]"]
              + [f"best after {n} [cm/s]" for n in args.checkpoints]
              + [f"best after {args.budget} [cm/s]", "per seed [cm/s]", "wall time [s]"])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    medians = {}
    for problem in problems:
        mine = [r for r in runs if r.problem == problem.name]
        if not mine:
            lines.append(f"| {problem.source} | `{rel(problem.config)}` | {problem.free or '-'} | "
                         + " | ".join(["-"] * (len(header) - 4)) + " |")
            continue
        medians[problem.source] = median([best(r) for r in mine])
        cells = [problem.source, f"`{rel(problem.config)}`", str(problem.free), lb.cm(median([r.start for r in mine]))]
        cells += [lb.cm(median([lb.best_after(r.result.best_so_far, n) for r in mine])) for n in args.checkpoints]
        cells += [lb.cm(medians[problem.source]), " / ".join(lb.cm(best(r)) for r in mine),
                  f"{statistics.median(r.result.wall_seconds for r in mine):.0f}"]
        lines.append("| " + " | ".join(cells) + " |")
    generated, hand = medians.get("generated"), medians.get("hand-made")
    if generated is not None and hand:
        ratio = generated / hand
        verdict = "met" if ratio >= 0.9 else "MISSED"
        summary = (f"Generated / hand-made median best after {args.budget}: {lb.cm(generated)} / {lb.cm(hand)} "
                   f"cm/s = {ratio:.3f} (target: generated within 10 % of hand-made, i.e. >= 0.9: {verdict}).")
    else:
        summary = "Generated / hand-made ratio: not available (a problem did not run)."
    return "\n".join(lines), summary


def robot_table(problems: list[Problem], runs: list[Run], configured: dict, checks: dict,
                timings: dict, args) -> str:
    header = ["robot", "free parameters", "configured gait [cm/s]", "generated start [cm/s]",
              f"best after {args.budget} [cm/s]", "seeds", "best / configured", "learns a faster gait",
              f"configured, eval seeds {args.check_text} [cm/s]", f"best, eval seeds {args.check_text} [cm/s]",
              "yamor-cpg-build [ms]"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for problem in problems:
        mine = [r for r in runs if r.problem == problem.name]
        conf = configured.get(problem.name)
        conf_text = lb.cm(conf) if isinstance(conf, float) else "error"
        top = median([best(r) for r in mine]) if mine else None
        if mine and isinstance(conf, float) and top is not None:
            ratio = f"{top / conf:.2f}" if conf > 0 else "-"
            faster = f"yes (+{100 * (top - conf):.2f} cm/s)" if top > conf else f"no ({100 * (top - conf):+.2f} cm/s)"
        else:
            ratio, faster = "-", "not run" if not mine else "-"
        check_conf = median(checks.get((problem.name, "configured"), []))
        check_best = median(checks.get((problem.name, "best"), []))
        time_ms = statistics.median(timings[problem.name]) * 1000 if timings.get(problem.name) else None
        cells = [problem.robot, str(problem.free) if problem.free is not None else "-", conf_text,
                 lb.cm(median([r.start for r in mine])) if mine else "-", lb.cm(top),
                 str(len(mine)), ratio, faster, lb.cm(check_conf), lb.cm(check_best),
                 f"{time_ms:.0f}" if time_ms is not None else "-"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def rel(path: Path) -> str:
    try:
        return str(path.relative_to(REPO))
    except ValueError:
        return str(path)


# --- main -----------------------------------------------------------------------------------

def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[2:]))
    parser.add_argument("--seeds", type=int, default=None, help="seeds per quadruped problem, (a) (3; quick 1)")
    parser.add_argument("--robot-seeds", type=int, default=None, help="seeds per robot, (b) (3; quick 1)")
    parser.add_argument("--budget", type=int, default=None, help="evaluations per run (300; quick 4)")
    parser.add_argument("--checkpoints", default=None,
                        help="comma-separated evaluation counts for table (a) (100; quick 2); "
                             "those at or above the budget are dropped")
    parser.add_argument("--robots", default=None,
                        help="comma-separated robots for (b) (default all): " + ", ".join(ROBOTS)
                        + "; 'none' for none")
    parser.add_argument("--no-quadruped", action="store_true", help="skip (a)")
    parser.add_argument("--check-seeds", default=None,
                        help="evaluation seeds to re-evaluate configured gaits and bests at (1,2,3; quick 1); "
                             "'none' for none")
    parser.add_argument("--timing-runs", type=int, default=None, help="yamor-cpg-build runs per robot (5; quick 2)")
    parser.add_argument("--quick", action="store_true",
                        help="tiny settings for tests: 1 seed, budget 4, 1 s + 2 s")
    parser.add_argument("--hosts", default=None, help="use these running daemons (H:P,H:P or @FILE)")
    parser.add_argument("--daemons", type=int, default=daemons.default_daemons(),
                        help="local daemons to start, one worker each (default: cores = %(default)s)")
    parser.add_argument("--out", default="results/generated-bench", help="results folder (%(default)s)")
    parser.add_argument("--build", default="build/release", help="build tree (default %(default)s)")
    parser.add_argument("--warmup", type=float, default=None, help="seconds before the measured span (8)")
    parser.add_argument("--duration", type=float, default=None, help="measured span [s] (12)")
    parser.add_argument("--reuse", action="store_true",
                        help="read a problem's runs from OUT/runs/ instead of running it again when every "
                             "seed there finished with this variant and budget (resume an interrupted run; warm-up and "
                             "duration are not recorded there, so give the same ones)")
    parser.add_argument("--quiet", action="store_true", help="no per-step progress lines")
    args = parser.parse_args(argv)
    for name, (small, full) in {"seeds": (1, 3), "robot_seeds": (1, 3), "budget": (4, 300),
                                "warmup": (1.0, 8.0), "duration": (2.0, 12.0), "checkpoints": ("2", "100"),
                                "check_seeds": ("1", "1,2,3"), "timing_runs": (2, 5)}.items():
        if getattr(args, name) is None:
            setattr(args, name, small if args.quick else full)
    if min(args.seeds, args.robot_seeds, args.budget, args.daemons, args.timing_runs) < 1:
        parser.error("--seeds, --robot-seeds, --budget, --daemons and --timing-runs must be at least 1")
    try:
        args.checkpoints = sorted({int(c) for c in args.checkpoints.split(",") if c.strip()})
        args.check_seeds = ([] if args.check_seeds == "none" else
                            sorted({int(c) for c in args.check_seeds.split(",") if c.strip()}))
    except ValueError:
        parser.error("--checkpoints and --check-seeds take comma-separated integers")
    args.checkpoints = [c for c in args.checkpoints if 0 < c < args.budget]
    args.check_text = ",".join(map(str, args.check_seeds)) or "-"
    if args.robots is None:
        args.robots = list(ROBOTS)
    elif args.robots == "none":
        args.robots = []
    else:
        names = [n.strip() for n in args.robots.split(",") if n.strip()]
        unknown = [n for n in names if n not in ROBOTS]
        if unknown:
            parser.error(f"--robots: unknown {', '.join(unknown)} (known: {', '.join(ROBOTS)})")
        args.robots = [r for r in ROBOTS if r in names]
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    bins = tool_paths(args.build)
    out = Path(args.out)
    if not out.is_absolute():
        out = Path.cwd() / out
    problems_dir = out / "problems"
    problems_dir.mkdir(parents=True, exist_ok=True)
    say = (lambda *a: None) if args.quiet else (lambda text: print(f"generated_bench: {text}", flush=True))
    print(f"generated_bench: {VARIANT.name} (`{VARIANT.describe()}`), budget {args.budget} evaluations of "
          f"{args.warmup:g} s + {args.duration:g} s; quadruped {'skipped' if args.no_quadruped else f'{args.seeds} seeds'}, "
          f"robots {', '.join(args.robots) or 'none'} x {args.robot_seeds} seeds", flush=True)
    notes: list[str] = []
    started = time.monotonic()
    quad_problems, robot_problems, runs = [], [], []
    configured, checks, timings = {}, {}, {}
    with daemons.open_pool(args, bins, out / "daemons") as pool:
        hosts = pool.hosts
        # The problems.
        if not args.no_quadruped:
            quad_problems = [Problem("quadruped-hand-made", "quadruped", "hand-made", HAND_MADE, world="quadruped",
                                     configured=QUADRUPED_ROBOT),
                             Problem("quadruped", "quadruped", "generated", problems_dir / "quadruped.xml",
                                     world="quadruped", configured=QUADRUPED_ROBOT)]
        for robot in args.robots:
            if robot == TRANSFORMED:
                try:
                    morphology = transformed_morphology(bins, hosts[0], problems_dir, notes)
                except ToolError as error:
                    problem = Problem(robot, robot, "generated", problems_dir / f"{robot}.xml",
                                      error=f"transformation: {error}")
                    robot_problems.append(problem)
                    continue
                robot_problems.append(Problem(robot, robot, "generated", problems_dir / f"{robot}.xml",
                                              morphology=morphology, configured=QUADRUPED_ROBOT))
            else:
                robot_problems.append(Problem(robot, robot, "generated", problems_dir / f"{robot}.xml",
                                              world=robot, configured=REPO / "configs" / "robots" / f"{robot}.xml"))
        generated = [p for p in quad_problems + robot_problems if p.source == "generated" and not p.error]
        for problem in generated:
            try:
                timings[problem.name] = generate(bins, problem, args.timing_runs, problems_dir)
                say(f"yamor-cpg-build {problem.robot}: {statistics.median(timings[problem.name]) * 1000:.0f} ms "
                    f"(median of {args.timing_runs})")
            except (ToolError, subprocess.TimeoutExpired) as error:
                problem.error = f"yamor-cpg-build: {error}"
        for problem in quad_problems + robot_problems:
            if not problem.error:
                problem.free = free_parameters(problem.config)

        # Configured gaits (one evaluation at the runs' evaluation seed).
        todo = [p for p in quad_problems[1:] + robot_problems if not p.error]
        values = evaluate_all(bins, hosts, [(p.name, p.body_argv(), p.configured, args, EVAL_SEED) for p in todo])
        for problem, value in zip(todo, values):
            configured[problem.name] = value
            if isinstance(value, str):
                problem.warnings.append(f"configured gait: {value}")
        if quad_problems:
            configured[quad_problems[0].name] = configured.get(quad_problems[1].name)

        # The learning runs.
        def learn(problem: Problem, count: int, hosts_arg: str) -> list[Run]:
            if problem.error:
                say(f"{problem.name}: not run: {problem.error}")
                return []
            try:
                mine = run_problem(problem, list(range(1, count + 1)), args, bins, hosts_arg, out)
            except ToolError as error:
                problem.error = f"yamor-optimize: {error}"
                say(f"{problem.name}: FAILED: {problem.error}")
                return []
            say(f"{problem.name}: best " + ", ".join(f"seed {r.seed} {lb.cm(best(r))}" for r in mine)
                + f" cm/s (start {lb.cm(mine[0].start)}){' (reused)' if problem.reused else ''}, "
                  f"{time.monotonic() - started:.0f} s so far")
            return mine

        for problem in quad_problems:
            runs += learn(problem, args.seeds, pool.hosts_arg())
        if args.robot_seeds == 1 and len(hosts) > 1:
            # One sequential run per robot: the robots run side by side, one daemon each.
            free_hosts: queue.Queue = queue.Queue()
            for h in hosts:
                free_hosts.put(h)

            def on_one_host(problem: Problem) -> list[Run]:
                h = free_hosts.get()
                try:
                    return learn(problem, 1, h)
                finally:
                    free_hosts.put(h)

            with ThreadPoolExecutor(max_workers=len(hosts)) as side_by_side:
                for mine in list(side_by_side.map(on_one_host, robot_problems)):
                    runs += mine
        else:
            for problem in robot_problems:
                runs += learn(problem, args.robot_seeds, pool.hosts_arg())

        # Re-evaluations at other evaluation seeds.
        jobs, keys = [], []
        for problem in quad_problems[1:] + robot_problems:
            if problem.error:
                continue
            for seed in args.check_seeds:
                jobs.append((problem.name, problem.body_argv(), problem.configured, args, seed))
                keys.append((problem.name, "configured", "configs", seed))
                for r in (r for r in runs if r.problem == problem.name):
                    best_xml = out / "runs" / problem.name / f"seed-{r.seed}" / "best.xml"
                    jobs.append((problem.name, problem.body_argv(), best_xml, args, seed))
                    keys.append((problem.name, "best", r.seed, seed))
        check_rows = []
        for key, value in zip(keys, evaluate_all(bins, hosts, jobs)):
            checks.setdefault(key[:2], []).append(value)
            check_rows.append((*key, value))
        pool_text = args.hosts if args.hosts else f"{args.daemons} local yamord x 1 worker"
    elapsed = time.monotonic() - started

    # Files.
    with open(out / "runs.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["problem", "robot", "source", "config", "seed", "status", "evaluations", "wall_seconds",
                         "start_cm_s", "best_cm_s"] + [f"best_after_{n}_cm_s" for n in args.checkpoints])
        by_name = {p.name: p for p in quad_problems + robot_problems}
        for r in runs:
            p = by_name[r.problem]
            writer.writerow([p.name, p.robot, p.source, rel(p.config), r.seed, r.result.status, r.result.evaluations,
                             repr(r.result.wall_seconds), lb.cm(r.start), lb.cm(best(r))]
                            + [lb.cm(lb.best_after(r.result.best_so_far, n)) for n in args.checkpoints])
    with open(out / "evaluations.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["problem", "gait", "run_seed", "eval_seed", "velocity_cm_s"])
        for name in configured:
            if name in by_name and by_name[name].source == "generated":
                value = configured[name]
                writer.writerow([name, "configured", "configs", EVAL_SEED,
                                 lb.cm(value) if isinstance(value, float) else value])
        for name, gait, run_seed, seed, value in check_rows:
            writer.writerow([name, gait, run_seed, seed, lb.cm(value) if isinstance(value, float) else value])
    with open(out / "cpg-build-times.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["robot", "run", "wall_seconds", "command"])
        for p in quad_problems + robot_problems:
            for i, t in enumerate(timings.get(p.name, [])):
                writer.writerow([p.robot, i + 1, repr(t),
                                 " ".join(rel(Path(a)) if isinstance(a, Path) else str(a)
                                          for a in cpg_build_argv(bins, p, p.config))])

    reused = [p.name for p in quad_problems + robot_problems if p.reused]
    sections = [f"# Generated optimization problems (issue 12)\n\n"
                f"`{VARIANT.describe()}` ({VARIANT.name}, the learning benchmark's best), budget "
                f"{args.budget} evaluations of {args.warmup:g} s warm-up + {args.duration:g} s walk, "
                f"evaluation seed {EVAL_SEED}; pool: {pool_text}; each problem's seeds ran at once on the pool"
                + (", and with one seed per robot the robots ran side by side, one daemon each"
                   if args.robot_seeds == 1 and len(hosts) > 1 and robot_problems else "")
                + f". Medians over seeds. Total {elapsed:.0f} s"
                + (f" (not counting the runs reused from an earlier invocation: {', '.join(reused)})" if reused else "")
                + "."]
    if quad_problems:
        table_a, summary_a = quadruped_table(quad_problems, runs, args)
        sections.append(f"## (a) Quadruped: generated against hand-made ({args.seeds} seeds)\n\n{table_a}\n\n{summary_a}")
    all_robots = quad_problems[1:] + robot_problems
    if all_robots:
        sections.append(
            f"## (b), (c) Configured gait against the generated problem's best ({args.robot_seeds} seed(s) per robot; "
            f"quadruped from (a), {args.seeds})\n\n"
            + robot_table(all_robots, runs, configured, checks, timings, args)
            + f"\n\n\"configured gait\": one evaluation of configs/robots/<robot>.xml on the robot's body "
              f"(the transformed quadruped: configs/robots/quadruped.xml on the new body) at evaluation seed "
              f"{EVAL_SEED}, as the runs evaluate; \"generated start\": the generated problem's start point (each "
              f"run's evaluation 0); \"learns a faster gait\": median best > configured gait. The two re-evaluation "
              f"columns are medians over evaluation seeds {args.check_text} (the best: of every run's best.xml). "
              f"yamor-cpg-build: wall time of the command, median of {args.timing_runs} runs.")
    problem_notes = [f"- {p.name}: {p.error}" for p in quad_problems + robot_problems if p.error]
    problem_notes += [f"- {p.name}: {w}" for p in quad_problems + robot_problems for w in p.warnings]
    if notes or problem_notes:
        sections.append("## Notes\n\n" + "\n".join([f"- {n}" for n in notes] + problem_notes))
    text = "\n\n".join(sections) + "\n"
    (out / "generated-bench.md").write_text(text)
    print()
    print(text)
    print(f"generated_bench: wrote {out / 'generated-bench.md'}, {out / 'runs.csv'}, {out / 'evaluations.csv'} "
          f"and {out / 'cpg-build-times.csv'}", flush=True)
    failed = [p for p in quad_problems + robot_problems if p.error]
    return 1 if failed and len(failed) == len(quad_problems + robot_problems) else 0


def cli() -> int:
    """The yamor-generated-bench command: main() with errors and Ctrl-C mapped to exit statuses."""
    return daemons.main_guard(main)


if __name__ == "__main__":
    sys.exit(cli())
