#!/usr/bin/env bash
# Wall time of processing N simulated sessions one after another (`relume process` per session)
# against `relume batch --local W` (workers forked, the default, and workers started as programs:
# --local-start exec), in R rounds on this machine, each round running the three one after the
# other so that a change in the machine's speed (a shared host) touches all three alike; then
# `--local 1` and an unchanged rerun once (docs/benchmarks.md, "Batches"). Prints each round, the
# median of each and the ratios of the medians. Sessions: tests/data/rigs/sim-tiny-irm.yaml,
# every pipeline (radiance and irm run; sh and radiosity say why they cannot).
#   scripts/batch_benchmark.sh [BUILD_DIR] [N] [W] [R]
set -euo pipefail
cd "$(dirname "$0")/.."
relume="${1:-build/release}/apps/relume/relume"
n="${2:-10}"
workers="${3:-2}"
rounds="${4:-5}"
tmp=$(mktemp -d /tmp/relume-batch-bench.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
for i in $(seq 1 "$n"); do
  "$relume" capture --rig tests/data/rigs/sim-tiny-irm.yaml --out "$tmp/field/day$i/session" >/dev/null 2>&1
done
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); awk "BEGIN {print $t1 - $t0}"; }
ratio() { awk "BEGIN {printf \"%.2f\", $1 / $2}"; }
median() { printf '%s\n' "$@" | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
finished() { grep -q "data-done=\"$n\"" "$1/index.html" || { echo "batch-benchmark: $1 did not finish" >&2; exit 1; }; }
printf '%s sessions on %s CPUs (%s), %s rounds\n' "$n" "$(nproc)" "$(date -u +%Y-%m-%d)" "$rounds"
printf '  round  one after another  --local %s exec  --local %s (fork)\n' "$workers" "$workers"
seq_times=() exec_times=() fork_times=()
for r in $(seq 1 "$rounds"); do
  rm -rf "$tmp"/field/*/processed "$tmp/batch-exec" "$tmp/batch-fork"
  s=$(seconds bash -c "for s in $tmp/field/*/session; do \"$relume\" process \"\$s\" --out \"\$s/../processed\" || exit 1; done")
  e=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-exec" --local "$workers" --local-start exec)
  f=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-fork" --local "$workers")
  finished "$tmp/batch-exec"
  finished "$tmp/batch-fork"
  printf '  %5s  %14.2f s  %12.2f s (%sx)  %12.2f s (%sx)\n' "$r" "$s" "$e" "$(ratio "$e" "$s")" "$f" "$(ratio "$f" "$s")"
  seq_times+=("$s")
  exec_times+=("$e")
  fork_times+=("$f")
done
ms=$(median "${seq_times[@]}")
me=$(median "${exec_times[@]}")
mf=$(median "${fork_times[@]}")
printf '  median %14.2f s  %12.2f s (%sx)  %12.2f s (%sx)\n' "$ms" "$me" "$(ratio "$me" "$ms")" "$mf" "$(ratio "$mf" "$ms")"
local1=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-1" --local 1)
finished "$tmp/batch-1"
rerun=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-fork" --local "$workers")
printf '  relume batch --local 1 (once):           %6.2f s  (%sx the median one after another)\n' "$local1" "$(ratio "$local1" "$ms")"
printf '  unchanged rerun, --local %s (once):       %6.2f s  (%sx)\n' "$workers" "$rerun" "$(ratio "$rerun" "$ms")"
