#!/usr/bin/env bash
# The `make demo` entry point: learns walking gaits for the quadruped's seven
# parameters (thesis Table 6.1) with two variants of the powell plugin, spread
# over two local yamord daemons, and writes the results folders.
#   tools/demo.sh BUILD_DIR      (e.g. build/release)
# Environment: DEMO_EVALUATIONS (budget per variant, default 300), DEMO_OUT (results folder).
set -euo pipefail
if [ $# -ne 1 ]; then echo "usage: $0 BUILD_DIR" >&2; exit 2; fi
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)"
cd "$root"

yamord="$build/host/yamord"
optimize="$build/optimizer-plugins/yamor-optimize"
for binary in "$yamord" "$optimize"; do
  [ -x "$binary" ] || { echo "demo: $binary not built (run make build)" >&2; exit 1; }
done
export YAMOR_PYTHON="$root/.venv/bin/python"
[ -x "$YAMOR_PYTHON" ] || { echo "demo: $YAMOR_PYTHON missing (run make deps)" >&2; exit 1; }

out="${DEMO_OUT:-results/demo}"
evaluations="${DEMO_EVALUATIONS:-300}"
rm -rf "$out"
mkdir -p "$out"

# Two daemons, one Evaluate worker each, on ports the kernel picks.
pids=()
hosts=()
cleanup() {
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT
for i in 1 2; do
  fifo="$out/.yamord$i.out"
  mkfifo "$fifo"
  "$yamord" --listen 127.0.0.1:0 --workers 1 --log-level warn >"$fifo" 2>"$out/yamord$i.log" &
  pids+=("$!")
  exec {fd}<"$fifo"
  line=""
  if ! read -r -t 60 -u "$fd" line || [[ "$line" != "yamord: listening on "* ]]; then
    echo "demo: yamord $i did not start (see $out/yamord$i.log)" >&2
    exit 1
  fi
  hosts+=("${line#yamord: listening on }")
  rm -f "$fifo"
  echo "demo: yamord $i listening on ${hosts[-1]}"
done
host_list="$(IFS=,; echo "${hosts[*]}")"

# Two Powell variants learn side by side over the pool (a batch start): the
# classic Brent line search with the statistics-based direction order (thesis
# 6.2.2, 6.4), best in docs/benchmarks.md's learning benchmark, and the
# interval line search (6.2.5), whose batches of 10 and 5 fill both daemons.
cat >"$out/batch.toml" <<TOML
[[instance]]
name = "powell-brent"
seed = 1
[instance.set]
line_search = "brent"
direction_order = "statistics"

[[instance]]
name = "powell-interval"
seed = 1
[instance.set]
line_search = "interval"
TOML
echo "demo: learning quadruped gaits with two powell variants side by side (thesis 6.2.2, 6.2.5)"
echo "demo: at most $evaluations evaluations each, of 8 s warm-up + 12 s walk, over $host_list"
"$optimize" --plugin powell --config configs/optimize/quadruped-7.xml --world quadruped \
  --hosts "$host_list" --set "max_evaluations=$evaluations" --batch "$out/batch.toml" \
  --seed 1 --out "$out"
