"""Issue 3's simulation benchmark in one run: yamor vs naive ODE vs MuJoCo.

Usage: yamor-physics-compare BUILD_DIR [--step S] [--repeats 5] [--sweep S1,S2,...]
                             [--sweep-gaits K] [--snakes 8,16,32,64] [--markdown OUT]
                             [--iterations N] [--sor W]

Needs a build with -DYAMOR_BUILD_BENCH=ON (BUILD_DIR/tools/bench/physics_bench
and BUILD_DIR/tools/mjcf/yamor-mjcf-export) and `mujoco` in the venv
(tools/requirements.txt). It

1. runs physics_bench (Google Benchmark, --repeats repetitions, medians):
   the 20-s quadruped evaluation through the bridge path and in the naive
   world, snake steps/s for ours and naive, and the step-size sweep;
2. exports the same robots with yamor-mjcf-export at the same step, has
   physics_bench write the set-points its CPG feeds the servos at that step,
   and runs yamor-mujoco-eval on them (--repeats repeats, medians);
3. prints one set of tables (and writes them as Markdown with --markdown):
   wall and CPU time per evaluation, steps/s, distance, ratios against our
   world measured in the same run, and the accuracy of each step against the
   finest.

Wall times suffer when the machine is shared; CPU times (the stepping
thread's) much less, so ratios are given for both. The load average at start
and end is printed.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from yamor.checkout import REPO

# Run by path in the interpreter that has mujoco (it imports nothing of yamor).
MUJOCO_EVAL = Path(__file__).resolve().with_name("mujoco_eval.py")


def fmt_steps(h):
    return f"{h * 1e3:g} ms"


def run(cmd, **kwargs):
    result = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kwargs)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"physics_compare: failed: {' '.join(str(c) for c in cmd)}")
    return result


def parse_bench(path):
    """Returns {run name without suffixes: entry} of medians and single runs."""
    with open(path) as f:
        data = json.load(f)
    out = {}
    for b in data["benchmarks"]:
        if b["run_type"] == "aggregate" and b.get("aggregate_name") != "median":
            continue
        name = b["run_name"].split("/iterations:")[0].split("/min_time:")[0]
        out[name] = b
    return out


def mujoco_run(args, tmp, robot, h, repeats, duration=None, skip=0.0, warmup=8.0):
    """Exports `robot` at step h and runs it in MuJoCo; returns the result dict."""
    tag = f"{robot}-{round(h * 1e6)}us"
    cmd = [args.bench, f"--export={robot}", f"--export_dir={tmp}", f"--step={h}"]
    if duration is not None:
        cmd.append(f"--export_duration={duration}")
    run(cmd)
    model = tmp / f"{tag}.mjcf.xml"
    unpowered = (tmp / f"{robot}.unpowered").read_text().strip()
    run([args.exporter, "--world", tmp / f"{robot}.world.xml", "--out", model,
         "--time-step", repr(h), "--log-level", "warn"]
        + (["--unpowered", unpowered] if unpowered else []))
    out = tmp / f"{tag}.mujoco.json"
    run([args.python, MUJOCO_EVAL, "--model", model,
         "--setpoints", tmp / f"{robot}.setpoints.csv", "--repeats", str(repeats),
         "--skip", str(skip), "--warmup", str(warmup), "--json", out])
    with open(out) as f:
        return json.load(f)


def table(headers, rows):
    """Markdown table, also readable as plain text."""
    cells = [headers] + [[str(c) for c in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = ["| " + " | ".join(c.ljust(w) for c, w in zip(cells[0], widths)) + " |",
             "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    for r in cells[1:]:
        lines.append("| " + " | ".join(c.rjust(w) for c, w in zip(r, widths)) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("build_dir", type=Path)
    parser.add_argument("--step", type=float, default=None,
                        help="step of the comparison (default: physics::WorldOptions')")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--sweep", default="0.00025,0.0005,0.001,0.002,0.004")
    parser.add_argument("--sweep-gaits", type=int, default=6)
    parser.add_argument("--snakes", default="8,16,32,64")
    parser.add_argument("--snake-window", type=float, default=0.5,
                        help="simulated s MuJoCo times per snake run (after 0.1 s untimed)")
    parser.add_argument("--iterations", type=int, default=None,
                        help="iterations of our iterative solver (default: WorldOptions')")
    parser.add_argument("--sor", type=float, default=None,
                        help="its over-relaxation factor (default: WorldOptions')")
    parser.add_argument("--markdown", type=Path, help="also write the tables here")
    args = parser.parse_args(argv)
    args.bench = args.build_dir / "tools/bench/physics_bench"
    args.exporter = args.build_dir / "tools/mjcf/yamor-mjcf-export"
    venv_python = REPO / ".venv/bin/python"
    args.python = venv_python if venv_python.exists() else Path(sys.executable)
    for binary in (args.bench, args.exporter):
        if not binary.exists():
            raise SystemExit(f"physics_compare: {binary} missing (build with "
                             "-DYAMOR_BUILD_BENCH=ON)")
    tmp = args.build_dir / "bench-results/physics"
    tmp.mkdir(parents=True, exist_ok=True)
    sweep = [float(s) for s in args.sweep.split(",")]
    snakes = [int(n) for n in args.snakes.split(",")]
    started = time.time()
    load_start = os.getloadavg()

    # 1. Our world and the naive one.
    bench_json = tmp / "physics_bench.json"
    cmd = [args.bench, f"--benchmark_repetitions={args.repeats}",
           "--benchmark_report_aggregates_only=true", f"--benchmark_out={bench_json}",
           "--benchmark_out_format=json", f"--sweep={args.sweep}",
           f"--sweep_gaits={args.sweep_gaits}", f"--snakes={args.snakes}"]
    if args.step is not None:
        cmd.append(f"--step={args.step}")
    if args.iterations is not None:
        cmd.append(f"--iterations={args.iterations}")
    if args.sor is not None:
        cmd.append(f"--sor={args.sor}")
    print(f"physics_compare: running {args.bench.name} ({args.repeats} repetitions)",
          file=sys.stderr)
    run(cmd)
    bench = parse_bench(bench_json)
    eval_name = next(n for n in bench if n.startswith("physics_quadruped_eval/"))
    h = bench[eval_name]["step_s"]
    step_tag = eval_name.split("/")[1]
    ours = bench[eval_name]
    naive = bench[f"physics_quadruped_eval_baseline/{step_tag}"]
    iterative = bench[f"physics_quadruped_eval_iterative/{step_tag}"]

    # 2. MuJoCo, same robots, same step, same set-points.
    print("physics_compare: running MuJoCo", file=sys.stderr)
    mj = mujoco_run(args, tmp, "quadruped", h, args.repeats)
    mj_sweep = {s: mujoco_run(args, tmp, "quadruped", s, 1) for s in sweep}
    mj_snakes = {n: mujoco_run(args, tmp, f"snake{n}", h, args.repeats,
                               duration=0.1 + args.snake_window, skip=0.1, warmup=0.1)
                 for n in snakes}
    load_end = os.getloadavg()

    out = []
    out.append(f"Step {fmt_steps(h)}; medians of {args.repeats} runs; MuJoCo {mj['mujoco']} "
               f"(mujoco.rollout, one thread); {os.cpu_count()} CPUs, load average "
               f"{load_start[0]:.2f} at start, {load_end[0]:.2f} at end; "
               f"{time.time() - started:.0f} s in all.")
    out.append("")

    # Quadruped evaluation.
    def eval_row(label, wall, cpu, steps, distance, diverged, bodies, joints):
        return [label, bodies, joints, f"{wall * 1e3:.0f}", f"{cpu * 1e3:.0f}",
                f"{steps / cpu:,.0f}", f"{distance:.3f}", "yes" if diverged else "no",
                f"{ours['eval_cpu_s'] / cpu:.2f}x" if label != "yamor (bridge path)" else "1x"]
    steps = round(20.0 / h)
    rows = [
        eval_row("yamor (bridge path)", ours["real_time"] / 1e3, ours["eval_cpu_s"], steps,
                 ours["distance_m"], ours["diverged"] > 0, int(ours["bodies"]),
                 int(ours["joints"])),
        eval_row("naive ODE", naive["real_time"] / 1e3, naive["eval_cpu_s"], steps,
                 naive["distance_m"], naive["diverged"] > 0, int(naive["bodies"]),
                 int(naive["joints"])),
        eval_row("yamor, iterative solver" + (f" ({args.iterations} it.)" if args.iterations else ""),
                 iterative["real_time"] / 1e3,
                 iterative["eval_cpu_s"], steps, iterative["distance_m"],
                 iterative["diverged"] > 0, int(iterative["bodies"]), int(iterative["joints"])),
        eval_row("MuJoCo", mj["median_wall_s"], mj["median_cpu_s"], mj["steps"],
                 mj["distance_m"], mj["diverged"], mj["bodies"], mj["joints"] - 1),
    ]
    out.append(f"### Quadruped, one 20-s evaluation (8 s warm-up + 12 s) at {fmt_steps(h)}")
    out.append("")
    out.append(table(["engine", "bodies", "joints", "wall ms", "CPU ms", "steps/CPU-s",
                      "distance m", "diverged", "speed vs yamor (CPU)"], rows))
    out.append("")
    speed_naive = naive["eval_cpu_s"] / ours["eval_cpu_s"]
    speed_naive_wall = naive["real_time"] / ours["real_time"]
    vs_mujoco = mj["median_cpu_s"] / ours["eval_cpu_s"]
    vs_mujoco_wall = mj["median_wall_s"] / (ours["real_time"] / 1e3)
    vs_mujoco_iterative = mj["median_cpu_s"] / iterative["eval_cpu_s"]
    out.append(f"- yamor / naive speed: {speed_naive:.2f}x CPU, {speed_naive_wall:.2f}x wall "
               f"(target >= 2x: {'met' if speed_naive >= 2 else 'MISSED'}).")
    out.append(f"- MuJoCo / yamor time per evaluation: {vs_mujoco:.2f} CPU, "
               f"{vs_mujoco_wall:.2f} wall (target >= 1, i.e. yamor no slower: "
               f"{'met' if vs_mujoco >= 1 else 'MISSED'}); with the iterative solver "
               f"{vs_mujoco_iterative:.2f} CPU, i.e. it takes {1 / vs_mujoco_iterative:.2f}x "
               f"MuJoCo's CPU time (issue 18's target <= 2x: "
               f"{'met' if vs_mujoco_iterative >= 0.5 else 'MISSED'}).")

    # Sweep.
    sweep_rows = []
    gaits = range(args.sweep_gaits + 1)
    ref = {k: bench[f"physics_step_sweep/{round(sweep[0] * 1e6)}us/gait{k}"]["distance_m"]
           for k in gaits}
    one_ms = None
    for s in sweep:
        entries = [bench[f"physics_step_sweep/{round(s * 1e6)}us/gait{k}"] for k in gaits]
        d0 = entries[0]["distance_m"]
        if abs(s - 0.001) < 1e-12:
            one_ms = d0
        errors = [abs(e["distance_m"] - ref[k]) / ref[k] for k, e in zip(gaits, entries)
                  if ref[k] > 0.05]
        within = sum(err <= 0.15 for err in errors)
        diverged = sum(e["diverged"] > 0 for e in entries)
        m = mj_sweep[s]
        it = bench[f"physics_step_sweep_iterative/{round(s * 1e6)}us/gait0"]
        it_text = f"{it['distance_m']:.3f}{' (diverged)' if it['diverged'] > 0 else ''}"
        sweep_rows.append([fmt_steps(s), f"{d0:.3f}", f"{100 * (d0 - ref[0]) / ref[0]:+.1f}%",
                           f"{100 * statistics.median(errors):.1f}%" if errors else "-",
                           f"{within}/{len(errors)}", diverged,
                           f"{entries[0]['eval_cpu_s'] * 1e3:.0f}",
                           f"{m['distance_m']:.3f}{' (diverged)' if m['diverged'] else ''}",
                           f"{m['median_cpu_s'] * 1e3:.0f}", it_text,
                           f"{it['eval_cpu_s'] * 1e3:.0f}"])
    out.append("")
    out.append(f"### Step size: quadruped distance (t = 8..20 s) against the "
               f"{fmt_steps(sweep[0])} run")
    out.append("")
    out.append(f"gait 0 = configs/robots/quadruped.xml; {args.sweep_gaits} more "
               "random gaits inside Table 6.1's bounds (seeds 1..K; only gaits that travel "
               "> 5 cm at the finest step count for the error).")
    out.append("")
    out.append(table(["step", "gait 0 m", "gait 0 error", "median |error| all gaits",
                      "within 15%", "diverged", "yamor CPU ms", "MuJoCo gait 0 m",
                      "MuJoCo CPU ms", "iterative gait 0 m", "iterative CPU ms"], sweep_rows))
    if one_ms:
        out.append("")
        out.append(f"- distance at {fmt_steps(h)} vs the 1-ms run (gait 0): "
                   f"{100 * (ours['distance_m'] - one_ms) / one_ms:+.1f}% (target within 15%).")

    # Snakes.
    snake_rows = []
    previous = None
    for n in snakes:
        a = bench[f"physics_snake_step/{n}"]
        b = bench[f"physics_snake_step_baseline/{n}"]
        it = bench[f"physics_snake_step_iterative/{n}"]
        m = mj_snakes[n]
        growth = f"{previous / a['items_per_second']:.1f}x" if previous else "-"
        previous = a["items_per_second"]
        snake_rows.append([n, int(a["bodies"]), int(b["bodies"]),
                           f"{a['items_per_second']:,.0f}", f"{b['items_per_second']:,.0f}",
                           f"{it['items_per_second']:,.0f}", f"{m['steps_per_cpu_s']:,.0f}",
                           f"{a['items_per_second'] / b['items_per_second']:.2f}x",
                           f"{a['items_per_second'] / m['steps_per_cpu_s']:.3f}x",
                           f"{it['items_per_second'] / m['steps_per_cpu_s']:.2f}x", growth])
    out.append("")
    out.append(f"### Snakes: steps per CPU-second at {fmt_steps(h)} (lying on the ground, gait "
               "starting; timed after 0.1 s)")
    out.append("")
    out.append(table(["modules", "bodies yamor", "bodies naive", "yamor", "naive",
                      "yamor iterative", "MuJoCo", "yamor/naive", "yamor/MuJoCo",
                      "iterative/MuJoCo", "yamor cost vs half size"], snake_rows))
    text = "\n".join(out) + "\n"
    print(text)
    if args.markdown:
        args.markdown.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
