#!/usr/bin/env bash
# The main job on the simulated rig: a day of capture at the simulated building site (a
# bracketing DSLR and an RGB-D sensor), then the session is verified and summarised.
# Calibration, processing and the report join this job as their issues land.
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
echo "== session"
"$relume" session info "$out/session"
echo "== the sun at the site that day"
"$relume" sun --site config/sites/athens-acropolis.yaml --time 2026-06-21T12:00:00+03:00
"$relume" sun --site config/sites/athens-acropolis.yaml --time 2026-06-21T00:00:00+03:00 \
  --until 2026-06-22T00:00:00+03:00 --step 60 > "$out/sun-2026-06-21.csv"
echo "demo: session in $out/session, the day's sun track in $out/sun-2026-06-21.csv"
