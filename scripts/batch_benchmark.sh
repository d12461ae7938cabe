#!/usr/bin/env bash
# Wall time of processing N simulated sessions one after another (`relume process` per session)
# against `relume batch --local 1` and `--local W` (workers forked, the default, and workers
# started as programs: --local-start exec), and of an unchanged rerun, in one run on this
# machine (docs/benchmarks.md, "Batches"). Sessions: tests/data/rigs/sim-tiny-irm.yaml, every
# pipeline (radiance and irm run; sh and radiosity say why they cannot).
#   scripts/batch_benchmark.sh [BUILD_DIR] [N] [W]
set -euo pipefail
cd "$(dirname "$0")/.."
relume="${1:-build/release}/apps/relume/relume"
n="${2:-10}"
workers="${3:-2}"
tmp=$(mktemp -d /tmp/relume-batch-bench.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
for i in $(seq 1 "$n"); do
  "$relume" capture --rig tests/data/rigs/sim-tiny-irm.yaml --out "$tmp/field/day$i/session" >/dev/null 2>&1
done
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); awk "BEGIN {print $t1 - $t0}"; }
ratio() { awk "BEGIN {printf \"%.2f\", $1 / $2}"; }
sequential=$(seconds bash -c "for s in $tmp/field/*/session; do \"$relume\" process \"\$s\" --out \"\$s/../processed\" || exit 1; done")
local1=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-1" --local 1)
localw_exec=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-w-exec" --local "$workers" --local-start exec)
localw=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-w" --local "$workers")
rerun=$(seconds "$relume" batch "$tmp/field/*/session" --out "$tmp/batch-w" --local "$workers")
for b in batch-1 batch-w-exec batch-w; do
  grep -q "data-done=\"$n\"" "$tmp/$b/index.html" || { echo "batch-benchmark: $b did not finish" >&2; exit 1; }
done
printf '%s sessions on %s CPUs (%s)\n' "$n" "$(nproc)" "$(date -u +%Y-%m-%d)"
printf '  one after another (relume process each): %6.2f s\n' "$sequential"
printf '  relume batch --local 1:                  %6.2f s  (%sx)\n' "$local1" "$(ratio "$local1" "$sequential")"
printf '  relume batch --local %s --local-start exec: %6.2f s  (%sx)\n' "$workers" "$localw_exec" "$(ratio "$localw_exec" "$sequential")"
printf '  relume batch --local %s:                  %6.2f s  (%sx)\n' "$workers" "$localw" "$(ratio "$localw" "$sequential")"
printf '  unchanged rerun, --local %s:              %6.2f s  (%sx)\n' "$workers" "$rerun" "$(ratio "$rerun" "$sequential")"
