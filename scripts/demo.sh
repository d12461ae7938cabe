#!/usr/bin/env bash
# The main job on the simulated rig. Until simulated capture exists (issue: capture), it is
# the sun for the sample site: one instant with rise/transit/set, and the day's time series.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh release
relume=build/release/apps/relume/relume
out=out/demo
mkdir -p "$out"
site=config/sites/athens-acropolis.yaml
"$relume" sun --site "$site" --time 2026-06-21T12:00:00+03:00
"$relume" sun --site "$site" --time 2026-06-21T00:00:00+03:00 --until 2026-06-22T00:00:00+03:00 --step 60 \
  > "$out/sun-2026-06-21.csv"
echo "demo: the day's sun track at 1-minute steps is in $out/sun-2026-06-21.csv ($(($(wc -l < "$out/sun-2026-06-21.csv") - 1)) rows)"
