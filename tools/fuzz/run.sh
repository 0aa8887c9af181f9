#!/usr/bin/env bash
# Runs every libFuzzer binary in BUILD_DIR/tests/fuzz for SECONDS each, from
# its checked-in seed corpus (tests/fuzz/corpus/<name>) plus a scratch corpus,
# with its dictionary (tests/fuzz/dict/<name>.dict) when there is one.
set -euo pipefail
build="$1"; seconds="$2"
root="$(cd "$(dirname "$0")/../.." && pwd)"
# A UBSan report ends the run as a finding (by default UBSan only prints and
# goes on, so batch_fuzzer's toml++ report passed unnoticed once).
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
found=0
for fuzzer in "$build"/tests/fuzz/*_fuzzer; do
  [ -x "$fuzzer" ] || continue
  found=1
  name=$(basename "$fuzzer")
  seeds="$root/tests/fuzz/corpus/$name"
  scratch="$build/corpus-run/$name"
  mkdir -p "$scratch"
  echo "fuzz: $name for ${seconds}s"
  args=("-max_total_time=$seconds" "-print_final_stats=1" "-artifact_prefix=$build/")
  dict="$root/tests/fuzz/dict/$name.dict"
  [ -f "$dict" ] && args+=("-dict=$dict")
  if [ -d "$seeds" ]; then "$fuzzer" "${args[@]}" "$scratch" "$seeds" 2>"$build/$name.log" || { tail -50 "$build/$name.log"; exit 1; }
  else "$fuzzer" "${args[@]}" "$scratch" 2>"$build/$name.log" || { tail -50 "$build/$name.log"; exit 1; }
  fi
  grep -E 'stat::number_of_executed_units' "$build/$name.log" || true
done
[ "$found" = 1 ] || { echo "fuzz: no fuzzers found in $build/tests/fuzz"; exit 1; }
