#!/usr/bin/env bash
# The main job on the simulated rig: a day of capture at the simulated building site (a
# bracketing DSLR and an RGB-D sensor), the DSLR's ColorChecker shot and its calibration,
# processing of the session through every pipeline, and the HTML report.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh release
relume=build/release/apps/relume/relume
out=out/demo
rm -rf "$out"
mkdir -p "$out"

echo "== capture: config/rigs/sim-outdoor.yaml (simulated DSLR + RGB-D, 08:00-18:00)"
"$relume" capture --rig config/rigs/sim-outdoor.yaml --out "$out/session"
echo "== verify"
"$relume" session verify "$out/session"
echo "== calibration: the DSLR's ColorChecker shot (config/rigs/sim-chart.yaml)"
"$relume" capture --rig config/rigs/sim-chart.yaml --out "$out/chart"
"$relume" calibrate chart --session "$out/chart" --frames bracket:1 --store-in "$out/session" \
  --out "$out/dslr-profile.json"
echo "== session"
"$relume" session info "$out/session"
echo "== processing: every pipeline the session supports, then the report"
"$relume" process "$out/session" --out "$out/processed"
echo "== the sun at the site that day"
"$relume" sun --site config/sites/athens-acropolis.yaml --time 2026-06-21T00:00:00+03:00 \
  --until 2026-06-22T00:00:00+03:00 --step 60 > "$out/sun-2026-06-21.csv"
echo "demo: report in $out/processed/report.html (session in $out/session, the day's sun track in $out/sun-2026-06-21.csv)"
