#!/usr/bin/env bash
# Runs every benchmark binary in BUILD_DIR/tools/bench (5 repetitions,
# aggregates only) and prints a table of medians. A benchmark named
# `X_baseline/...` is the same-run baseline of `X/...`; the table shows the
# ratio median(X) / median(X_baseline) of their items/s (for cpg_bench:
# oscillator-steps/s, one RK4 step of every oscillator per iteration).
# Programs listed in `plain_programs` are not Google Benchmark binaries: each
# runs once (it repeats internally) and its own table is printed after ours.
# Last, yamor-physics-compare prints the simulation comparison with
# MuJoCo (when the venv has mujoco), and yamor-film-bench the cost of
# a filmed Evaluate through a real yamord (when ffmpeg is installed).
set -euo pipefail
plain_programs=" host_bench pool_bench serial_bench render_bench tracker_bench physics_accuracy gp_bench "
if [ $# -lt 1 ]; then echo "usage: $0 BUILD_DIR [extra benchmark flags]" >&2; exit 2; fi
build="$1"; shift
root="$(cd "$(dirname "$0")/../.." && pwd)"
bench_dir="$build/tools/bench"
py=python3
[ -x "$root/.venv/bin/python" ] && py="$root/.venv/bin/python"
out_dir="$build/bench-results"
mkdir -p "$out_dir"

found=0
jsons=()
plain_outputs=()
for bin in "$bench_dir"/*; do
  [ -f "$bin" ] && [ -x "$bin" ] || continue
  found=1
  name=$(basename "$bin")
  if [[ "$plain_programs" == *" $name "* ]]; then
    echo "bench: $name (plain program)" >&2
    "$bin" "$@" >"$out_dir/$name.txt" 2>&1 || { cat "$out_dir/$name.txt" >&2; exit 1; }
    plain_outputs+=("$out_dir/$name.txt")
    continue
  fi
  json="$out_dir/$name.json"
  echo "bench: $name (5 repetitions)" >&2
  "$bin" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
    --benchmark_out="$json" --benchmark_out_format=json "$@" >"$out_dir/$name.txt" 2>&1 \
    || { cat "$out_dir/$name.txt" >&2; exit 1; }
  jsons+=("$json")
done
[ "$found" = 1 ] || { echo "bench: no benchmark binaries in $bench_dir (configure with -DYAMOR_BUILD_BENCH=ON)" >&2; exit 1; }

"$py" - "${jsons[@]}" <<'PY'
import json
import sys

rows = []
for path in sys.argv[1:]:
    with open(path) as f:
        data = json.load(f)
    context = data.get("context", {})
    stats = {}
    for b in data["benchmarks"]:
        if b.get("run_type") != "aggregate":
            continue
        entry = stats.setdefault(b["run_name"], {})
        entry[b["aggregate_name"]] = b
    for run_name, agg in stats.items():
        median = agg.get("median")
        if median is None:
            continue
        items = median.get("items_per_second")
        cv = agg.get("cv", {}).get("items_per_second") if items else agg.get("cv", {}).get("real_time")
        rows.append((run_name, items, median, cv))
    if context:
        print(f"# {path}: {context.get('num_cpus')} cpus @ {context.get('mhz_per_cpu')} MHz, "
              f"libbenchmark build {context.get('library_build_type')}")

by_name = {name: items for name, items, _, _ in rows}

def baseline_of(name):
    head, _, rest = name.partition("/")
    candidate = head + "_baseline" + ("/" + rest if rest else "")
    return by_name.get(candidate)

def fmt_rate(value):
    return f"{value:,.0f}" if value is not None else "-"

width = max([len(r[0]) for r in rows] + [9])
print(f"{'benchmark':<{width}}  {'median items/s':>16}  {'cv':>6}  {'vs baseline':>11}")
for name, items, median, cv in rows:
    cv_text = f"{100 * cv:.1f}%" if cv is not None else "-"
    if items is None:
        rate = f"{median['real_time']:.4g} {median.get('time_unit', '')}"
    else:
        rate = fmt_rate(items)
    base = baseline_of(name)
    ratio = f"{items / base:.1f}x" if items and base else ""
    print(f"{name:<{width}}  {rate:>16}  {cv_text:>6}  {ratio:>11}")
PY

for output in "${plain_outputs[@]}"; do
  echo
  cat "$output"
done

# Issue 3's side-by-side simulation figures (yamor vs naive ODE vs MuJoCo,
# step sweep, snakes) need the MJCF exporter and `mujoco` in the venv.
if [ -x "$build/tools/mjcf/yamor-mjcf-export" ] && "$py" -c "import mujoco" 2>/dev/null; then
  echo
  echo "bench: physics_compare.py (yamor vs naive ODE vs MuJoCo, 2 ms)" >&2
  "$py" -m yamor.tools.physics_compare "$build" --step 0.002 \
    --markdown "$out_dir/physics_compare.md"
else
  echo "bench: skipping physics_compare.py (needs $build/tools/mjcf/yamor-mjcf-export and mujoco)" >&2
fi

# Issue 14's end-to-end film cost (a real yamord: an MP4 made by the daemon,
# PNG frames made into a video here) against the evaluation it shows.
if command -v ffmpeg > /dev/null; then
  echo
  echo "bench: film_bench.py (a filmed Evaluate through a real yamord)" >&2
  "$py" -m yamor.tools.film_bench --build "$build"
else
  echo "bench: skipping film_bench.py (needs ffmpeg)" >&2
fi
