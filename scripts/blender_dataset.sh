#!/usr/bin/env bash
# Images from outside relume (issue 19): scenes rendered by Blender Cycles (scripts/blender/),
# turned into sessions the way a field team's files would be, and processed against Blender's
# own renders as the truth.
#
#   scripts/blender_dataset.sh RELUME OUT [--scene courtyard|room|rgbd] [--bounces N] [--samples N] [--seed N]
#       [--format jpeg|tiff]
#
# courtyard (default; scripts/blender/render_courtyard.py): the sun where `relume sun` puts it at
#   09:30 and 15:30 local time, a uniform sky; `--pipeline irm` relights the morning to the
#   afternoon and is scored against Blender's afternoon render (docs/irm.md). Default: 0 bounces
#   (the IRM model's assumption), 64 samples. `--seed N` (N > 0): a random courtyard, day and
#   times drawn from N (scripts/blender_suite.sh runs many).
# room (scripts/blender/render_room.py): a room with interreflection (default 8 bounces), a point
#   lamp of stated intensity in two places, a grey-scale chart of known albedo; `--pipeline
#   radiosity` estimates every material's albedo (absolute, from the chart) and relights with a
#   new lamp, scored against the true albedo and Blender's render under that lamp
#   (docs/radiosity.md).
# rgbd (scripts/blender/render_rgbd.py): an RGB-D recording, 12 frames at 30 fps of three objects
#   under a distant key light circling them and a fixed fill (tests/data/scenes/sh-moving-light.yaml
#   rendered by Cycles, default 3 bounces): 8-bit sRGB colour PNGs and 16-bit millimetre depth
#   PNGs in the TUM RGB-D layout, imported with `relume session import --rgbd`; `--pipeline sh`
#   relights every frame to the last one's light and is scored against Blender's linear render at
#   that time (docs/processing-sh.md).
# Steps, each what a user does with real files:
#  1. Blender renders linear EXRs (the truth), five-frame 8-bit JPEG brackets through its sRGB
#     view (the camera), the geometry as OBJ files (the survey) and the camera.
#  2. exiv2 writes each JPEG's EXIF as a camera would: DateTimeOriginal (1 s apart within a
#     bracket), OffsetTimeOriginal, ExposureTime (1/250 s at the middle frame), FNumber, ISO,
#     Make, Model.
#  3. `relume session import` makes the session; `relume session add-scene-model --from
#     scene.yaml` adds the camera, the OBJ meshes and (room) the lamp and the chart's albedo.
#  4. `relume process` with `--set truth_dir=OUT/truth`.
# Exit codes: 0 done, 77 Blender or exiv2 missing (the tests are then skipped), other: a failure.
set -euo pipefail

usage="usage: blender_dataset.sh RELUME OUT [--scene courtyard|room|rgbd] [--bounces N] [--samples N] [--seed N] [--format jpeg|tiff]"
relume=${1:?$usage}
out=${2:?$usage}
shift 2
scene=courtyard
bounces=""
samples=64
seed=0
format=jpeg
while [[ $# -gt 0 ]]; do
  case $1 in
    --seed) seed=${2:?$usage} ;;
    --format) format=${2:?$usage} ;;
    --scene) scene=${2:?$usage} ;;
    --bounces) bounces=${2:?$usage} ;;
    --samples) samples=${2:?$usage} ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
  shift 2
done
case $scene in
  courtyard) bounces=${bounces:-0} ;;
  room) bounces=${bounces:-8} ;;
  rgbd) bounces=${bounces:-3} ;;
  *) echo "blender_dataset: --scene is courtyard, room or rgbd" >&2; exit 2 ;;
esac
case $format in
  jpeg) ext=jpg ;;
  tiff) ext=tif ;;
  *) echo "blender_dataset: --format is jpeg or tiff" >&2; exit 2 ;;
esac
if [[ $format == tiff && $scene != courtyard ]]; then
  echo "blender_dataset: --format tiff is for the courtyard" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
for tool in blender exiv2; do
  if ! command -v "$tool" >/dev/null; then
    echo "blender_dataset: $tool is not installed (scripts/install-deps.sh installs it): skipped" >&2
    exit 77
  fi
done

rm -rf "$out"
mkdir -p "$out/render" "$out/truth" "$out/photos"
site="$out/site.yaml"
cat >"$site" <<'YAML'
name: zurich
latitude_deg: 47.37689
longitude_deg: 8.54169
height_m: 460.0
YAML

# render SCRIPT ARGS...: Blender in the background, its log kept.
render() {
  local script=$1
  shift
  echo "blender_dataset: rendering $scene with Blender Cycles (${bounces} diffuse bounces, ${samples} samples per pixel)"
  blender -b --factory-startup -noaudio -P "$here/blender/$script" -- "$out/render" "$@" \
    --bounces "$bounces" --samples "$samples" >"$out/blender.log" 2>&1 || {
    tail -20 "$out/blender.log" >&2
    exit 1
  }
}

# photograph NAME DAY TIME OFFSET: NAME's five JPEGs (or TIFFs) into photos/ with the EXIF a camera writes,
# the frames 1 s apart from TIME (HH:MM:SS, local), exposure 1/250 s at EV 0.
photograph() {
  local name=$1 day=$2 time=$3 offset=$4 seconds=0 ev exposure file stamp
  for ev in -2 -1 +0 +1 +2; do
    file="$out/photos/${name}_ev${ev}.$ext"
    cp "$out/render/${name}_ev${ev}.$ext" "$file"
    case $ev in -2) exposure="1/1000" ;; -1) exposure="1/500" ;; +0) exposure="1/250" ;; +1) exposure="1/125" ;; +2) exposure="2/125" ;; esac
    stamp="${day//-/:} ${time%:*}:$(printf '%02d' $((10#${time##*:} + seconds)))"
    exiv2 -k \
      -M"set Exif.Image.Make Ascii Blender" \
      -M"set Exif.Image.Model Ascii Cycles" \
      -M"set Exif.Photo.DateTimeOriginal Ascii $stamp" \
      -M"set Exif.Photo.OffsetTimeOriginal Ascii $offset" \
      -M"set Exif.Photo.ExposureTime Rational $exposure" \
      -M"set Exif.Photo.FNumber Rational 8/1" \
      -M"set Exif.Photo.ISOSpeedRatings Short 100" \
      "$file"
    seconds=$((seconds + 1))
  done
}

# scene_file KIND: scene.yaml from the render's camera.json and OBJ files (what a survey gives).
scene_file() {
  python3 - "$out" "$1" <<'PY'
import json, sys, os
out, kind = sys.argv[1], sys.argv[2]
camera = json.load(open(os.path.join(out, "render", "camera.json")))
lines = ["# The scene as a field team would describe it (scripts/blender_dataset.sh).",
         "cameras:", "  - device: import:blender-cycles",
         "    intrinsics: {width: %d, height: %d, horizontal_fov_deg: %r}"
         % (camera["width"], camera["height"], camera["horizontal_fov_deg"]),
         "    position_m: %s" % list(camera["position_m"]), "    look_at_m: %s" % list(camera["look_at_m"]),
         "objects:"]
prefix = "courtyard" if kind == "courtyard" else "room"
names = sorted(f[len(prefix) + 1:-4] for f in os.listdir(os.path.join(out, "render"))
               if f.startswith(prefix + "_") and f.endswith(".obj"))
surfaces = {"ground", "floor", "ceiling", "wall-west", "wall-east", "wall-south", "wall-north", "chart"}
for name in names:
    lines.append("  - {name: %s, kind: %s, mesh: render/%s_%s.obj}"
                 % (name, "surface" if name in surfaces else "solid", prefix, name))
if kind == "room":
    truth = json.load(open(os.path.join(out, "render", "albedo.json")))
    lines.append("known_albedo:   # the chart's data sheet")
    for name, a in sorted(truth.items()):
        if name.startswith("chart/"):
            lines.append("  - {material: %s, albedo: %s}" % (name, list(a)))
    # The lamp: at A for the first bracket (19:00:00-19:00:04 UTC), at B for the second (19:01).
    a, b = camera["lamp_a_m"], camera["lamp_b_m"]
    lines += ["lamps:", "  - name: lamp", "    type: point",
              "    intensity_w_sr: %s" % ([camera["intensity_w_sr"]] * 3),
              "    track:",
              "      - {utc: \"2026-01-15T19:00:00Z\", position_m: %s}" % list(a),
              "      - {utc: \"2026-01-15T19:00:10Z\", position_m: %s}" % list(a),
              "      - {utc: \"2026-01-15T19:00:50Z\", position_m: %s}" % list(b),
              "      - {utc: \"2026-01-15T19:01:10Z\", position_m: %s}" % list(b)]
open(os.path.join(out, "scene.yaml"), "w").write("\n".join(lines) + "\n")
PY
}

if [[ $scene == rgbd ]]; then
  # The recording as an RGB-D sensor's tools write it: no EXIF, the intrinsics from the camera's
  # calibration (here Blender's camera), the timestamps in rgb.txt and depth.txt.
  render render_rgbd.py
  intrinsics=$(python3 -c 'import json, sys
c = json.load(open(sys.argv[1]))
print("%r,%r,%r,%r" % (c["fx"], c["fy"], c["cx"], c["cy"]))' "$out/render/camera.json")
  "$relume" session import --rgbd "$out/render/rgbd" --intrinsics "$intrinsics" --out "$out/session" \
    --site "$site" --camera-id blender-cycles-rgbd
  cp -r "$out/render/truth/." "$out/truth/"
  "$relume" process "$out/session" --pipeline sh --out "$out/sh" --set "truth_dir=$out/truth"
  exit 0
fi

if [[ $scene == courtyard ]]; then
  day=2026-06-21
  am=09:30:00
  pm=15:30:00
  if [[ $seed != 0 ]]; then
    # A day from April to September and a morning and an afternoon time, drawn from the seed.
    read -r day am pm < <(python3 -c '
import datetime, random, sys
r = random.Random(int(sys.argv[1]) * 7919)
day = datetime.date(2026, 4, 1) + datetime.timedelta(days=r.randint(0, 182))
minutes = lambda lo, hi: "%02d:%02d:00" % divmod(r.randint(lo, hi), 60)
print(day.isoformat(), minutes(7 * 60 + 30, 10 * 60 + 30), minutes(13 * 60 + 30, 17 * 60))' "$seed")
  fi
  specs=()
  for spec in am:$am pm:$pm; do
    name=${spec%%:*}
    json=$("$relume" sun --site "$site" --time "${day}T${spec#*:}+02:00" --json)
    az=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["azimuth_deg"])' <<<"$json")
    el=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["elevation_deg"])' <<<"$json")
    specs+=("$name:$az:$el")
  done
  render render_courtyard.py "${specs[@]}" --seed "$seed" --format "$format"
  photograph am "$day" "$am" +02:00
  photograph pm "$day" "$pm" +02:00
  scene_file courtyard
  cp "$out/render/pm_independent.exr" "$out/truth/target.exr"
  # The truths are independent renders (another sampling seed): the relit image is scored
  # without sharing the photographs' Monte Carlo noise, and the floor (the source photograph
  # against its truth) then holds that noise, which a relit image inherits, besides the
  # encoding's error.
  cp "$out/render/am_independent.exr" "$out/truth/source.exr"
  cp "$out/render/am_sun.exr" "$out/truth/source_sun.exr"
  cp "$out/render/pm_sun.exr" "$out/truth/target_sun.exr"
else
  render render_room.py
  photograph a 2026-01-15 20:00:00 +01:00
  photograph b 2026-01-15 20:01:00 +01:00
  scene_file room
  cp "$out/render/albedo.json" "$out/render/relit.exr" "$out/render/relit.json" "$out/truth/"
fi

linear=()
[[ $format == tiff ]] && linear=(--linear)
"$relume" session import "$out/photos" --out "$out/session" --site "$site" --camera-id blender-cycles "${linear[@]}"
"$relume" session add-scene-model "$out/session" --from "$out/scene.yaml"
if [[ $scene == courtyard ]]; then
  "$relume" process "$out/session" --pipeline irm --out "$out/irm" --set "truth_dir=$out/truth"
else
  "$relume" process "$out/session" --pipeline radiosity --out "$out/radiosity" --set "truth_dir=$out/truth" \
    --set material_groups=wall-west+wall-east,wall-south+wall-north,desk-leg-west+desk-leg-east
fi
