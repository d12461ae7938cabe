#!/usr/bin/env bash
# Images from outside relume (issue 19): a courtyard rendered by Blender Cycles
# (scripts/blender/render_courtyard.py) in the morning and the afternoon, turned into a session
# the way a field team's files would be, and relit with the IRM pipeline against Blender's truth.
#
#   scripts/blender_dataset.sh RELUME OUT [--bounces N] [--samples N]
#
# Steps, each what a user does with real files:
#  1. `relume sun` gives the sun's azimuth and elevation at the site for 09:30 and 15:30 local
#     time; Blender renders the courtyard under that sun and a uniform sky: a linear EXR (the
#     truth), a bracket of five 8-bit JPEGs through its sRGB view at EV -2 .. +2, the sun's
#     visible fraction per pixel, the geometry as OBJ files and the camera.
#  2. exiv2 writes each JPEG's EXIF as a camera would: DateTimeOriginal (1 s apart within a
#     bracket), OffsetTimeOriginal, ExposureTime (1/250 s at EV 0), FNumber, ISO, Make, Model.
#  3. `relume session import` makes the session (files kept byte for byte, brackets grouped, the
#     sun per frame); `relume session add-scene-model --from scene.yaml` adds the camera (its
#     position and look-at point, 60 deg field of view) and the OBJ meshes.
#  4. `relume process --pipeline irm --set truth_dir=OUT/truth` relights the morning to the
#     afternoon and compares with Blender's afternoon render per region (docs/irm.md).
# Exit codes: 0 done, 77 Blender or exiv2 missing (the test is then skipped), other: a failure.
set -euo pipefail

usage="usage: blender_dataset.sh RELUME OUT [--bounces N] [--samples N]"
relume=${1:?$usage}
out=${2:?$usage}
shift 2
bounces=0
samples=64
while [[ $# -gt 0 ]]; do
  case $1 in
    --bounces) bounces=${2:?$usage} ;;
    --samples) samples=${2:?$usage} ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
  shift 2
done
here=$(cd "$(dirname "$0")" && pwd)
for tool in blender exiv2; do
  if ! command -v "$tool" >/dev/null; then
    echo "blender_dataset: $tool is not installed (scripts/install-deps.sh installs it): skipped" >&2
    exit 77
  fi
done

rm -rf "$out"
mkdir -p "$out/render" "$out/truth"
site="$out/site.yaml"
cat >"$site" <<'YAML'
name: zurich-courtyard
latitude_deg: 47.37689
longitude_deg: 8.54169
height_m: 460.0
YAML
day=2026-06-21
declare -A local_time=([am]="09:30:00" [pm]="15:30:00")
specs=()
for name in am pm; do
  json=$("$relume" sun --site "$site" --time "${day}T${local_time[$name]}+02:00" --json)
  az=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["azimuth_deg"])' <<<"$json")
  el=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["elevation_deg"])' <<<"$json")
  specs+=("$name:$az:$el")
done

echo "blender_dataset: rendering with Blender Cycles (${bounces} diffuse bounces, ${samples} samples per pixel)"
blender -b --factory-startup -noaudio -P "$here/blender/render_courtyard.py" -- "$out/render" "${specs[@]}" \
  --bounces "$bounces" --samples "$samples" >"$out/blender.log" 2>&1 || {
  tail -20 "$out/blender.log" >&2
  exit 1
}

# EXIF, as the camera would have written it.
mkdir -p "$out/photos"
for name in am pm; do
  seconds=0
  for ev in -2 -1 +0 +1 +2; do
    file="$out/photos/${name}_ev${ev}.jpg"
    cp "$out/render/${name}_ev${ev}.jpg" "$file"
    # 1/250 s at EV 0: 1/1000 .. 1/62.5 s.
    case $ev in -2) exposure="1/1000" ;; -1) exposure="1/500" ;; +0) exposure="1/250" ;; +1) exposure="1/125" ;; +2) exposure="2/125" ;; esac
    stamp="${day//-/:} ${local_time[$name]%:00}:$(printf '%02d' "$seconds")"
    exiv2 -k \
      -M"set Exif.Image.Make Ascii Blender" \
      -M"set Exif.Image.Model Ascii Cycles" \
      -M"set Exif.Photo.DateTimeOriginal Ascii $stamp" \
      -M"set Exif.Photo.OffsetTimeOriginal Ascii +02:00" \
      -M"set Exif.Photo.ExposureTime Rational $exposure" \
      -M"set Exif.Photo.FNumber Rational 8/1" \
      -M"set Exif.Photo.ISOSpeedRatings Short 100" \
      "$file"
    seconds=$((seconds + 1))
  done
done

# The scene model: the camera as measured on site, the meshes of the survey.
python3 - "$out" <<'PY'
import json, sys, os
out = sys.argv[1]
camera = json.load(open(os.path.join(out, "render", "camera.json")))
objects = ["ground", "hall", "tower", "annex", "wall"]
with open(os.path.join(out, "scene.yaml"), "w") as f:
    f.write("# The courtyard as a field team would describe it (scripts/blender_dataset.sh).\n")
    f.write("cameras:\n  - device: import:blender-cycles\n")
    f.write("    intrinsics: {width: %d, height: %d, horizontal_fov_deg: %r}\n"
            % (camera["width"], camera["height"], camera["horizontal_fov_deg"]))
    f.write("    position_m: %s\n    look_at_m: %s\n" % (list(camera["position_m"]), list(camera["look_at_m"])))
    f.write("objects:\n")
    for o in objects:
        kind = "surface" if o == "ground" else "solid"
        f.write("  - {name: %s, kind: %s, mesh: render/courtyard_%s.obj}\n" % (o, kind, o))
PY

"$relume" session import "$out/photos" --out "$out/session" --site "$site" --camera-id blender-cycles
"$relume" session add-scene-model "$out/session" --from "$out/scene.yaml"
cp "$out/render/pm.exr" "$out/truth/target.exr"
cp "$out/render/am.exr" "$out/truth/source.exr"
cp "$out/render/am_sun.exr" "$out/truth/source_sun.exr"
cp "$out/render/pm_sun.exr" "$out/truth/target_sun.exr"
"$relume" process "$out/session" --pipeline irm --out "$out/irm" --set "truth_dir=$out/truth"
