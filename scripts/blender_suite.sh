#!/usr/bin/env bash
# IRM on random courtyards rendered by Blender Cycles: scripts/blender_dataset.sh --seed 1..N
# (random buildings, albedos, sky level, day and times), each imported and relit against
# Blender's own render; prints the relit error per region with its floor (the linearised source
# photograph itself) as median, p90 and worst over the scenes, and writes OUT/suite.csv.
#
#   scripts/blender_suite.sh RELUME OUT [N (10)] [--bounces N]
# Exit 77 when Blender or exiv2 is missing.
set -euo pipefail
relume=${1:?usage: blender_suite.sh RELUME OUT [N] [--bounces N]}
out=${2:?usage: blender_suite.sh RELUME OUT [N] [--bounces N]}
count=${3:-10}
shift $(($# < 3 ? $# : 3))
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
echo "seed,relit_lit,relit_shadow,relit_penumbra,floor_lit,floor_shadow,not_relit_lit,not_relit_shadow,lit_pixels,shadow_pixels" \
  >"$out/suite.csv"
for seed in $(seq 1 "$count"); do
  set +e
  bash "$here/blender_dataset.sh" "$relume" "$out/seed-$seed" --seed "$seed" "$@" >"$out/seed-$seed.log" 2>&1
  rc=$?
  set -e
  [[ $rc == 77 ]] && { cat "$out/seed-$seed.log" >&2; exit 77; }
  if [[ $rc != 0 ]]; then
    echo "blender_suite: seed $seed failed (see $out/seed-$seed.log)" >&2
    echo "$seed,nan,nan,nan,nan,nan,nan,nan,0,0" >>"$out/suite.csv"
    continue
  fi
  python3 - "$out/seed-$seed/irm/summary.json" "$seed" >>"$out/suite.csv" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["metrics"]["truth"]
r, f, n = t["relit"], t["source_photograph"], t["no_relighting"]
print(",".join(str(v) for v in (sys.argv[2], r["relative_rms_lit"], r["relative_rms_shadow"], r["relative_rms_penumbra"],
                               f["relative_rms_lit"], f["relative_rms_shadow"], n["relative_rms_lit"],
                               n["relative_rms_shadow"], r["lit_pixels"], r["shadow_pixels"])))
PY
done
python3 - "$out/suite.csv" <<'PY'
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
def stats(key):
    v = sorted(float(r[key]) for r in rows if not math.isnan(float(r[key])))
    if not v:
        return "n/a"
    p = lambda q: v[min(len(v) - 1, int(round(q * (len(v) - 1))))]
    return "%.2f / %.2f / %.2f %%" % (100 * p(0.5), 100 * p(0.9), 100 * v[-1])
failed = sum(math.isnan(float(r["relit_lit"])) for r in rows)
print("blender_suite: %d scenes (%d failed); median / p90 / worst" % (len(rows), failed))
for key in ("relit_lit", "floor_lit", "relit_shadow", "floor_shadow", "relit_penumbra", "not_relit_lit",
            "not_relit_shadow"):
    print("  %-16s %s" % (key, stats(key)))
PY
