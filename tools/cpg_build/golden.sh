#!/usr/bin/env bash
# Golden outputs of yamor-cpg-build: the generated problem (optimization XML
# and --explain) of every world of configs/worlds/ under every option the docs
# name, and of the bodies and gaits the lifelong scenarios rebuild networks
# for (configs/lifelong). A refactor of cpg/problem.cc must leave them
# byte-identical.
#
#   golden.sh BUILD_TOOL OUT_DIR           the checked-in case set
#   golden.sh BUILD_TOOL OUT_DIR --full    also --no-symmetry and budgets 1-7 x seeds 1,2,7
#                                          (with and without --impose-symmetry) for every world
#   golden.sh BUILD_TOOL OUT_DIR --check EXPECTED_DIR
#                                          the checked-in set, then diff -r against EXPECTED_DIR
#
# tests/cpg/golden/expected holds the checked-in set (ctest CpgGolden checks
# it); regenerate it with `golden.sh build/release/tools/cpg_build/yamor-cpg-build
# tests/cpg/golden/expected` only for a change that is meant to change problems.
set -euo pipefail

if [[ $# -lt 2 ]]; then
  echo "usage: $0 YAMOR_CPG_BUILD OUT_DIR [--full | --check EXPECTED_DIR]" >&2
  exit 2
fi
tool=$(realpath "$1")
out=$2
mode=${3:-}
expected=${4:-}
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"

[[ $mode == --check ]] && rm -rf "$out"
mkdir -p "$out"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# The lifelong scenarios' starting gait without its <optimize>/<constrain>
# rules: yamor-lifelong hands GenerateProblem the robot configuration only.
walking=$scratch/quadruped-walking-robot.xml
grep -v -e '<optimize ' -e '<constrain ' configs/lifelong/quadruped-walking.xml > "$walking"
inputs=tests/cpg/golden/inputs

# One case: NAME then the tool's arguments. The output file holds the XML and
# the --explain text, so loops, notes and the start robot are all compared.
run() {
  local name=$1
  shift
  local xml=$scratch/$name.xml
  "$tool" "$@" --explain -o "$xml" > "$scratch/$name.explain"
  { cat "$xml"; echo "----- explain -----"; cat "$scratch/$name.explain"; } > "$out/$name.txt"
}

for path in configs/worlds/*.xml; do
  w=$(basename "$path" .xml)
  run "$w" --world "$w"
  run "$w-nobase" --morphology "$path"
  run "$w-nobase-max3-seed2" --morphology "$path" --max-free 3 --seed 2
  run "$w-no-mirrors" --world "$w" --no-mirrors
  run "$w-ignore-gravity" --world "$w" --ignore-gravity
  run "$w-impose-symmetry" --world "$w" --impose-symmetry
  run "$w-keep-inactive" --world "$w" --keep-inactive
  run "$w-max3-seed2" --world "$w" --max-free 3 --seed 2
  run "$w-max5-seed7" --world "$w" --max-free 5 --seed 7
  if [[ $mode == --full ]]; then
    run "$w-no-symmetry" --world "$w" --no-symmetry
    for budget in 1 2 3 4 5 6 7; do
      for seed in 1 2 7; do
        run "$w-full-max$budget-seed$seed" --world "$w" --max-free "$budget" --seed "$seed"
        run "$w-full-impose-max$budget-seed$seed" --world "$w" --impose-symmetry --max-free "$budget" --seed "$seed"
      done
    done
  fi
done
run quadruped-keep-free --world quadruped --keep-free 0-1 --keep-free 2-3
run quadruped-passive-knees --world quadruped --passive 5,6
run quadruped-driven-centre --world quadruped --driven 4

# Lifelong (configs/lifelong/*.toml): the starting gait on each world, and the
# networks rebuilt after a body change (imposed ties, the life's seed + n - 1;
# yamor-lifelong --base-ties-only turns the imposing off).
for w in quadruped lifelong/quadruped-spare lifelong/quadruped-extended lifelong/quadruped-extended-table; do
  morph=configs/worlds/$w.xml
  [[ $w == lifelong/* ]] && morph=configs/$w.xml
  run "lifelong-$(basename "$w")" --morphology "$morph" --base "$walking"
done
for seed in 1 2; do
  run "lifelong-transformed-seed$seed" --morphology $inputs/quadruped-transformed.xml --base "$walking" \
    --impose-symmetry --seed $seed
  run "lifelong-inserted-seed$seed" --morphology $inputs/quadruped-inserted.xml --base "$walking" \
    --driven 9 --impose-symmetry --seed $seed
  run "lifelong-defect5-seed$seed" --world quadruped --base "$walking" --passive 5 --impose-symmetry --seed $seed
done
run lifelong-transformed-base-ties-only --morphology $inputs/quadruped-transformed.xml --base "$walking"
run lifelong-transformed-robots-base --morphology $inputs/quadruped-transformed.xml \
  --base configs/robots/quadruped.xml --impose-symmetry
run lifelong-transformed-max3 --morphology $inputs/quadruped-transformed.xml --base "$walking" \
  --impose-symmetry --max-free 3 --seed 5

if [[ $mode == --check ]]; then
  diff -r "$expected" "$out"
fi
