"""Learning benchmark: every optimizer plugin (and Powell variant) on the quadruped's seven parameters.

Usage: yamor-learning-bench [--seeds 5] [--budget 1000] [--plugins NAME,...] [--quick]
                            [--hosts H:P,...] [--daemons N] [--out results/learning-bench]
                            [--warmup 8] [--duration 12] [--build build/release]

For each variant and seed it runs yamor-optimize on
configs/optimize/quadruped-7.xml (thesis Table 6.1) with `max_evaluations` =
--budget, then reports per variant, as medians over the seeds:

  * the best velocity after 100, 300 and 1000 evaluations (--checkpoints;
    a run that converged earlier keeps its final best),
  * the evaluations needed to reach 95 % of the best velocity any run of any
    variant found ("-" counts as never; "(k/n)" says how many seeds reached it),
  * the wall time of one run.

Runs go one after another, each alone on the whole pool, so wall time is what a
user with this pool waits: parallel plugins (pso, cmaes, powell interval) use
every worker, sequential ones (simplex, powell brent) one. --parallel-seeds
runs a variant's seeds at once instead (faster in total; wall times shared). The table (Markdown)
is printed and written to OUT/learning-bench.md, the per-run numbers to
OUT/runs.csv and every run's results folder to OUT/runs/<variant>/seed-<n>/.

grid is not benchmarked: it is a landscape tool, not an optimizer for seven
parameters (3 points per axis are already 3^7 = 2187 evaluations, more than the
budget; 2 per axis only visits the box's corners).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from yamor.checkout import REPO
from yamor.tools import daemons
from yamor.tools.daemons import ToolError

CONFIG = REPO / "configs" / "optimize" / "quadruped-7.xml"
GRID_REASON = ("grid: not an optimizer for 7 parameters (3 points per axis = 3^7 = 2187 "
               "evaluations > budget; 2 per axis visits only the corners)")


@dataclass(frozen=True)
class Variant:
    """One benchmarked configuration: a plugin and its fields."""

    name: str
    plugin: str
    sets: tuple[tuple[str, str], ...] = ()

    def describe(self) -> str:
        fields = " ".join(f"{k}={v}" for k, v in self.sets)
        return f"{self.plugin} {fields}".strip()


VARIANTS = [
    Variant("powell-brent-constant", "powell", (("line_search", "brent"), ("bounds", "constant"))),
    Variant("powell-brent-stadium", "powell", (("line_search", "brent"), ("bounds", "stadium"))),
    Variant("powell-brent-easy-direction", "powell",
            (("line_search", "brent"), ("bounds", "easy-direction"))),
    Variant("powell-interval", "powell", (("line_search", "interval"),)),
    Variant("powell-statistics", "powell",
            (("line_search", "brent"), ("direction_order", "statistics"))),
    Variant("pso", "pso"),
    Variant("cmaes", "cmaes"),
    Variant("bayesopt", "bayesopt"),
    Variant("bayesopt-global", "bayesopt", (("trust_region", "0"), ("periodic_phases", "false"))),
    Variant("simplex", "simplex"),
    Variant("random", "random"),
]
BY_NAME = {v.name: v for v in VARIANTS}


@dataclass
class RunResult:
    """One run's numbers (velocities in m/s)."""

    variant: str
    seed: int
    evaluations: int
    status: str
    wall_seconds: float
    best_so_far: list[float]


def read_best_so_far(evaluations_csv: Path) -> list[float]:
    best, curve = -math.inf, []
    with open(evaluations_csv, newline="") as f:
        for row in csv.DictReader(f):
            best = max(best, float(row["velocity"]))
            curve.append(best)
    return curve


def best_after(curve: list[float], n: int) -> float | None:
    """Best velocity within the first n evaluations (a shorter, converged run keeps its final best)."""
    if not curve:
        return None
    return curve[min(n, len(curve)) - 1]


def evaluations_to_reach(curve: list[float], threshold: float) -> int | None:
    """1-based count of evaluations until the best reaches `threshold`; None if never."""
    for i, value in enumerate(curve):
        if value >= threshold:
            return i + 1
    return None


def median_with_never(values: list[int | None]) -> float | None:
    """Median where None (never reached) ranks above every number; None when the median is never."""
    ranked = sorted(values, key=lambda v: math.inf if v is None else v)
    n = len(ranked)
    if n == 0:
        return None
    middle = ranked[(n - 1) // 2], ranked[n // 2]
    if middle[0] is None or middle[1] is None:
        return None
    return (middle[0] + middle[1]) / 2


def optimize_argv(variant: Variant, args, bins, hosts: str, out: Path) -> list[str]:
    argv = ["--plugin", variant.plugin, "--plugin-dir", str(bins["plugins"]), "--config", str(CONFIG),
            "--world", "quadruped", "--hosts", hosts, "--warmup", repr(args.warmup),
            "--duration", repr(args.duration), "--no-plot", "--no-video",
            "--set", f"max_evaluations={args.budget}", "--out", str(out)]
    for key, value in variant.sets:
        argv += ["--set", f"{key}={value}"]
    return argv


def read_run(variant: Variant, seed: int, run_dir: Path) -> RunResult:
    summary = json.loads((run_dir / "summary.json").read_text())
    if summary["status"] not in ("budget", "converged"):
        raise ToolError(f"{run_dir}: run ended {summary['status']}: {summary.get('error', '')}")
    return RunResult(variant.name, seed, int(summary["evaluations"]), summary["status"],
                     float(summary["wall_seconds"]), read_best_so_far(run_dir / "evaluations.csv"))


def run_variant(variant: Variant, seeds: list[int], args, bins, hosts: str, out: Path) -> list[RunResult]:
    """Every seed of one variant: one run after another, or (--parallel-seeds) one batch."""
    variant_dir = out / "runs" / variant.name
    variant_dir.mkdir(parents=True, exist_ok=True)
    if args.parallel_seeds:
        batch = variant_dir / "batch.toml"
        batch.write_text("".join(f'[[instance]]\nname = "seed-{seed}"\nseed = {seed}\n\n' for seed in seeds))
        daemons.run_optimize(bins["optimize"],
                             optimize_argv(variant, args, bins, hosts, variant_dir) + ["--batch", str(batch)],
                             quiet=True, log=variant_dir / "yamor-optimize.log")
        return [read_run(variant, seed, variant_dir / f"seed-{seed}") for seed in seeds]
    results = []
    for seed in seeds:
        run_dir = variant_dir / f"seed-{seed}"
        run_dir.mkdir(parents=True, exist_ok=True)
        daemons.run_optimize(bins["optimize"],
                             optimize_argv(variant, args, bins, hosts, run_dir) + ["--seed", str(seed)],
                             quiet=True, log=run_dir / "yamor-optimize.log")
        results.append(read_run(variant, seed, run_dir))
    return results


def cm(value: float | None) -> str:
    return "-" if value is None else f"{100.0 * value:.2f}"


def table(results: list[RunResult], variants: list[Variant], checkpoints: list[int], budget: int,
          seeds: int) -> tuple[str, float]:
    """The Markdown table and the best velocity any run found."""
    overall = max((r.best_so_far[-1] for r in results if r.best_so_far), default=0.0)
    threshold = overall - 0.05 * abs(overall)
    header = (["variant", "fields"] + [f"best after {n} [cm/s]" for n in checkpoints]
              + [f"best after {budget} [cm/s]", "evals to 95 % of best", "wall time [s]"])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for variant in variants:
        runs = [r for r in results if r.variant == variant.name]
        if not runs:
            continue
        cells = [variant.name, f"`{variant.describe()}`"]
        for n in checkpoints + [budget]:
            values = [best_after(r.best_so_far, n) for r in runs]
            values = [v for v in values if v is not None]
            cells.append(cm(statistics.median(values)) if values else "-")
        reach = [evaluations_to_reach(r.best_so_far, threshold) for r in runs]
        reached = sum(v is not None for v in reach)
        median = median_with_never(reach)
        cells.append(("-" if median is None else f"{median:g}") + f" ({reached}/{len(runs)})")
        cells.append(f"{statistics.median(r.wall_seconds for r in runs):.0f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines), overall


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[2:]))
    parser.add_argument("--seeds", type=int, default=None, help="seeds per variant (5; quick 2)")
    parser.add_argument("--budget", type=int, default=None, help="evaluations per run (1000; quick 8)")
    parser.add_argument("--checkpoints", default=None,
                        help="comma-separated evaluation counts to report (100,300,1000; quick 2,4); "
                             "those above the budget are dropped")
    parser.add_argument("--plugins", default=None,
                        help="comma-separated variants (default all): " + ", ".join(BY_NAME)
                        + "; a plugin name (powell) selects all its variants")
    parser.add_argument("--quick", action="store_true",
                        help="tiny settings for tests: 2 seeds, budget 8, 1 s + 2 s")
    parser.add_argument("--hosts", default=None, help="use these running daemons (H:P,H:P or @FILE)")
    parser.add_argument("--daemons", type=int, default=daemons.default_daemons(),
                        help="local daemons to start, one worker each (default: cores = %(default)s)")
    parser.add_argument("--out", default="results/learning-bench", help="results folder (%(default)s)")
    parser.add_argument("--build", default="build/release", help="build tree (default %(default)s)")
    parser.add_argument("--warmup", type=float, default=None, help="seconds before the measured span (8)")
    parser.add_argument("--duration", type=float, default=None, help="measured span [s] (12)")
    parser.add_argument("--parallel-seeds", action="store_true",
                        help="run a variant's seeds at once (one --batch) so sequential plugins fill "
                             "the pool: faster in total, but wall times are then shared-pool times")
    parser.add_argument("--quiet", action="store_true", help="no per-run progress lines")
    args = parser.parse_args(argv)
    for name, (small, full) in {"seeds": (2, 5), "budget": (8, 1000), "warmup": (1.0, 8.0),
                                "duration": (2.0, 12.0), "checkpoints": ("2,4", "100,300,1000")}.items():
        if getattr(args, name) is None:
            setattr(args, name, small if args.quick else full)
    if args.seeds < 1 or args.budget < 1 or args.daemons < 1:
        parser.error("--seeds, --budget and --daemons must be at least 1")
    try:
        args.checkpoints = sorted({int(c) for c in args.checkpoints.split(",") if c.strip()})
    except ValueError:
        parser.error(f"--checkpoints {args.checkpoints!r}: not a list of integers")
    args.checkpoints = [c for c in args.checkpoints if 0 < c < args.budget]
    if args.plugins:
        chosen = []
        for name in (n.strip() for n in args.plugins.split(",") if n.strip()):
            if name == "grid":
                parser.error(GRID_REASON)
            matches = [v for v in VARIANTS if v.name == name or v.plugin == name]
            if not matches:
                parser.error(f"--plugins: unknown variant {name!r} (known: {', '.join(BY_NAME)})")
            chosen += [v for v in matches if v not in chosen]
        args.variants = [v for v in VARIANTS if v in chosen]  # the table keeps one order
    else:
        args.variants = list(VARIANTS)
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    bins = daemons.binaries(args.build)
    out = Path(args.out)
    if not out.is_absolute():
        out = Path.cwd() / out
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(1, args.seeds + 1))
    total = len(args.variants) * len(seeds)
    print(f"learning_bench: {len(args.variants)} variants x {len(seeds)} seeds, {args.budget} "
          f"evaluations of {args.warmup:g} s + {args.duration:g} s each; excluded: {GRID_REASON}",
          flush=True)
    results: list[RunResult] = []
    started = time.monotonic()
    with daemons.open_pool(args, bins, out / "daemons") as pool:
        for variant in args.variants:
            for result in run_variant(variant, seeds, args, bins, pool.hosts_arg(), out):
                results.append(result)
                if not args.quiet:
                    best = result.best_so_far[-1] if result.best_so_far else None
                    print(f"learning_bench: [{len(results)}/{total}] {variant.name} seed {result.seed}: "
                          f"{result.status} after {result.evaluations} evaluations, best "
                          f"{cm(best)} cm/s, {result.wall_seconds:.0f} s", flush=True)
    elapsed = time.monotonic() - started

    with open(out / "runs.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["variant", "seed", "status", "evaluations", "wall_seconds", "best_cm_s"]
                        + [f"best_after_{n}_cm_s" for n in args.checkpoints])
        for r in results:
            writer.writerow([r.variant, r.seed, r.status, r.evaluations, repr(r.wall_seconds),
                             cm(r.best_so_far[-1] if r.best_so_far else None)]
                            + [cm(best_after(r.best_so_far, n)) for n in args.checkpoints])
    markdown, overall = table(results, args.variants, args.checkpoints, args.budget, len(seeds))
    pool_text = args.hosts if args.hosts else f"{args.daemons} local yamord x 1 worker"
    sharing = (f"a variant's {len(seeds)} seeds ran at once (--parallel-seeds), so wall time is "
               f"that of a run sharing the pool" if args.parallel_seeds else "each run alone on the pool")
    text = (f"# Learning benchmark: quadruped, seven parameters (thesis Table 6.1)\n\n"
            f"Medians over {len(seeds)} seeds (1..{len(seeds)}); budget {args.budget} evaluations of "
            f"{args.warmup:g} s warm-up + {args.duration:g} s walk; pool: {pool_text}; "
            f"{sharing}. Best velocity any run found: {cm(overall)} cm/s; the 95 % column counts "
            f"evaluations until a run's best reaches {cm(overall - 0.05 * abs(overall))} cm/s "
            f"(median, \"-\" = never; (k/n) runs reached it). Total {elapsed:.0f} s.\n\n"
            f"{markdown}\n\nNot run: {GRID_REASON}.\n")
    (out / "learning-bench.md").write_text(text)
    print()
    print(text)
    print(f"learning_bench: wrote {out / 'learning-bench.md'} and {out / 'runs.csv'}", flush=True)
    return 0


def cli() -> int:
    """The yamor-learning-bench command: main() with errors and Ctrl-C mapped to exit statuses."""
    return daemons.main_guard(main)


if __name__ == "__main__":
    sys.exit(cli())
