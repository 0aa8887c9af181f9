#!/usr/bin/env bash
# The `make demo` entry point: integrates the quadruped's CPG (thesis 6.1.1)
# for 20 s from seeded random initial phases (all-zero phases would sit on the
# unstable in-phase equilibrium of the hip ring) and plots every set-point.
#   tools/demo.sh BUILD_DIR      (e.g. build/release)
set -euo pipefail
if [ $# -ne 1 ]; then echo "usage: $0 BUILD_DIR" >&2; exit 2; fi
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)"
cd "$root"

runner="$build/cpg/yamor-cpg-run"
[ -x "$runner" ] || { echo "demo: $runner not built (run make build)" >&2; exit 1; }
python=".venv/bin/python"
[ -x "$python" ] || { echo "demo: $python missing (run make deps)" >&2; exit 1; }

config="configs/robots/quadruped.xml"
out="results/demo"
mkdir -p "$out"

"$runner" --config "$config" --duration 20 --dt 0.001 --sample-dt 0.01 \
  --seed 1 --out "$out/setpoints.csv"
"$python" tools/plot/plot_setpoints.py "$out/setpoints.csv" "$out/setpoints.png" \
  --title "Quadruped CPG set-points (thesis 6.1.1, $config)"

echo "demo: set-points CSV: $root/$out/setpoints.csv"
echo "demo: plot:           $root/$out/setpoints.png"
