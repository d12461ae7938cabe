"""A courtyard rendered by Blender Cycles: relume's test data from a renderer that is not relume.

Run by scripts/blender_dataset.sh (which says what the outputs are for):
    blender -b --factory-startup -P scripts/blender/render_courtyard.py -- OUT NAME:AZ:EL ... [--bounces N]
        [--samples N] [--seed N] [--format jpeg|tiff]
`--seed N` (N > 0) draws a random courtyard from N (3-5 buildings, albedos, the sky's level);
0, the default, is the fixed one below.

For each NAME (a time of day, the sun at azimuth AZ and apparent elevation EL in degrees, the
azimuth from north toward east as `relume sun` gives it) it writes into OUT:
  NAME.exr            the photograph in scene-linear Rec.709 radiance (float RGB; the truth)
  NAME_ev-2.jpg ...   the same through Blender's sRGB display transform at EV -2 .. +2 about
                      BASE_EV (8-bit
                      JPEG: the camera's bracket; the script's caller adds the EXIF), or with
                      `--format tiff` 16-bit linear TIFFs NAME_ev-2.tif ... (no view transform: a
                      raw converter's output, nearly free of quantisation and response error:
                      what the method does without the photographs' own error)
  NAME_independent.exr  NAME.exr rendered again with another sampling seed (independent noise)
  NAME_sun.exr        R: the fraction of the sun's disk each pixel's surface sees (the sun-only
                      render over the same with shadows off), G: 1 where a surface is, 0 sky
and once: courtyard_<object>.obj (the geometry in the site's ENU frame, metres, one file per
object) and camera.json (position, look-at point, horizontal field of view, size).

Conventions: Blender's world axes are the site's ENU axes (x east, y north, z up); every
surface is Lambertian (a Diffuse BSDF); the sky is uniform above the horizon and black below it
(the world shader); the sun is
Blender's sun lamp with the real sun's angular diameter; pixel filter 0.01 px (no blur across
shadow edges); `--bounces 0` (default) renders direct light only, the IRM model's assumption.
"""
import json
import math
import os
import random
import sys

import bpy
import mathutils

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (scripts/blender/common.py)

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) < 2:
    sys.exit("usage: blender -b -P render_courtyard.py -- OUT NAME:AZ:EL ... [--bounces N] [--samples N] [--seed N]")
bounces = 0
samples = 64
seed = 0  # 0: the fixed courtyard; N > 0: a random one drawn from N (the same N, the same scene)
if "--seed" in argv:
    i = argv.index("--seed")
    seed = int(argv[i + 1])
    del argv[i:i + 2]
if "--bounces" in argv:
    i = argv.index("--bounces")
    bounces = int(argv[i + 1])
    del argv[i:i + 2]
if "--samples" in argv:
    i = argv.index("--samples")
    samples = int(argv[i + 1])
    del argv[i:i + 2]
photo_format = "jpeg"  # the bracket's files: 8-bit JPEG (a camera's) or 16-bit TIFF (nearly no quantisation)
if "--format" in argv:
    i = argv.index("--format")
    photo_format = argv[i + 1]
    del argv[i:i + 2]
    if photo_format not in ("jpeg", "tiff"):
        sys.exit("--format is jpeg or tiff")
out = argv[0]
times = []
for spec in argv[1:]:
    name, az, el = spec.split(":")
    times.append((name, float(az), float(el)))
os.makedirs(out, exist_ok=True)

WIDTH, HEIGHT, HFOV_DEG = 200, 150, 60.0
CAMERA = (-30.0, -24.0, 9.0)
LOOK_AT = (0.0, 2.0, 3.0)
SUN_W_M2 = 1000.0  # irradiance on a surface facing the sun
SKY = (25.0, 30.0, 40.0)  # uniform sky radiance, W m^-2 sr^-1 (the world colour at strength 1)
# The photographs' exposure: Blender's view exposure (EV) of the middle frame. The lit ground's
# radiance is about 60 W m^-2 sr^-1, so EV -8 puts it near mid grey (0.23) before the sRGB curve.
BASE_EV = -8.0
BRACKET_EV = (-2, -1, 0, 1, 2)  # the bracket's frames, EV about BASE_EV
JPEG_QUALITY = 97

scene = bpy.context.scene
common.clear_scene()

bpy.ops.mesh.primitive_plane_add(size=80.0, location=(0, 0, 0))
ground = bpy.context.active_object
ground.name = "ground"
if seed == 0:
    ground.data.materials.append(common.material("ground", (0.30, 0.28, 0.25)))
    common.box("hall", (0.0, 6.0, 4.0), (14.0, 6.0, 8.0), (0.70, 0.62, 0.50))
    common.box("tower", (-9.0, -2.0, 7.0), (3.0, 3.0, 14.0), (0.45, 0.48, 0.52))
    common.box("annex", (8.0, -3.0, 2.0), (5.0, 5.0, 4.0), (0.60, 0.35, 0.30))
    common.box("wall", (-1.0, -6.0, 1.0), (8.0, 0.4, 2.0), (0.80, 0.80, 0.78))
else:
    # A random courtyard: 3-5 buildings (2-10 m wide, 2-15 m high) that do not overlap, placed
    # where the camera sees them, every surface a grey of 0.15-0.85 tinted 0.85-1.15 per channel
    # (the ground 0.15-0.45), and a sky of 15-40 W m^-2 sr^-1 with a random blue tint.
    rng = random.Random(seed)

    def tinted(lo, hi):
        grey = rng.uniform(lo, hi)
        return tuple(min(0.95, grey * rng.uniform(0.85, 1.15)) for _ in range(3))

    ground.data.materials.append(common.material("ground", tinted(0.15, 0.45)))
    placed = []
    count = rng.randint(3, 5)
    for _ in range(1000):
        if len(placed) == count:
            break
        w, d, h = rng.uniform(2, 10), rng.uniform(2, 10), rng.uniform(2, 15)
        x, y = rng.uniform(-14, 12), rng.uniform(-8, 12)
        if any(abs(x - px) < (w + pw) / 2 + 1 and abs(y - py) < (d + pd) / 2 + 1 for px, py, pw, pd in placed):
            continue
        placed.append((x, y, w, d))
        common.box("building-%d" % len(placed), (x, y, h / 2), (w, d, h), tinted(0.15, 0.85))
    level = rng.uniform(15, 40)
    SKY = (level * rng.uniform(0.75, 0.9), level * rng.uniform(0.9, 1.0), level * 1.2)

common.camera(CAMERA, LOOK_AT, math.radians(HFOV_DEG), WIDTH, HEIGHT)

# The sky: uniform above the horizon, black below it (the earth), so that a facade above the
# finite ground plane does not see sky beneath the horizon.
world = bpy.data.worlds.new("sky")
world.use_nodes = True
tree = world.node_tree
background = tree.nodes["Background"]
background.inputs["Strength"].default_value = 1.0
direction = tree.nodes.new("ShaderNodeTexCoord")
split = tree.nodes.new("ShaderNodeSeparateXYZ")
above = tree.nodes.new("ShaderNodeMath")
above.operation = "GREATER_THAN"
above.inputs[1].default_value = 0.0
sky_colour = tree.nodes.new("ShaderNodeRGB")
mask = tree.nodes.new("ShaderNodeMixRGB")
mask.blend_type = "MULTIPLY"
mask.inputs["Fac"].default_value = 1.0
tree.links.new(direction.outputs["Generated"], split.inputs[0])
tree.links.new(split.outputs["Z"], above.inputs[0])
tree.links.new(sky_colour.outputs[0], mask.inputs["Color1"])
tree.links.new(above.outputs[0], mask.inputs["Color2"])
tree.links.new(mask.outputs["Color"], background.inputs["Color"])
scene.world = world

sun_data = bpy.data.lights.new("sun", "SUN")
sun_data.angle = math.radians(0.53)
sun = bpy.data.objects.new("sun", sun_data)
scene.collection.objects.link(sun)

common.cycles(samples, bounces)
render_to = common.save_render


for name, az, el in times:
    a, e = math.radians(az), math.radians(el)
    toward_sun = mathutils.Vector((math.sin(a) * math.cos(e), math.cos(a) * math.cos(e), math.sin(e)))
    sun.rotation_euler = toward_sun.to_track_quat("Z", "Y").to_euler()  # the lamp shines along its -Z
    # The photograph: sun and sky.
    sun_data.energy = SUN_W_M2
    sun_data.cycles.cast_shadow = True
    sky_colour.outputs[0].default_value = (*SKY, 1.0)
    scene.render.film_transparent = False
    bpy.ops.render.render()
    render_to(os.path.join(out, name + ".exr"), "OPEN_EXR", "32")
    for ev in BRACKET_EV:
        if photo_format == "jpeg":
            render_to(os.path.join(out, "%s_ev%+d.jpg" % (name, ev)), "JPEG", "8", exposure=BASE_EV + ev,
                      quality=JPEG_QUALITY)
        else:
            render_to(os.path.join(out, "%s_ev%+d.tif" % (name, ev)), "TIFF", "16", exposure=BASE_EV + ev, linear=True)
    # The same photograph with another sampling seed: a truth independent of the photograph's
    # own Monte Carlo noise (the floor a relit image is held to, blender_dataset.sh).
    scene.cycles.seed = 7
    bpy.ops.render.render()
    render_to(os.path.join(out, name + "_independent.exr"), "OPEN_EXR", "32")
    scene.cycles.seed = 0
    # The sun's visible fraction: sun only, with and without shadows; alpha marks surfaces.
    sky_colour.outputs[0].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.render.film_transparent = True
    bpy.ops.render.render()
    shadowed = bpy.data.images["Render Result"]
    path_shadowed = os.path.join(out, name + "_sun_shadowed.exr")
    render_to(path_shadowed, "OPEN_EXR", "32", color_mode="RGBA")
    sun_data.cycles.cast_shadow = False
    bpy.ops.render.render()
    path_open = os.path.join(out, name + "_sun_open.exr")
    render_to(path_open, "OPEN_EXR", "32", color_mode="RGBA")
    sun_data.cycles.cast_shadow = True
    a_img = bpy.data.images.load(path_shadowed)
    b_img = bpy.data.images.load(path_open)
    pa, pb = list(a_img.pixels), list(b_img.pixels)
    fraction = [0.0] * len(pa)
    for i in range(0, len(pa), 4):
        open_sum = pb[i] + pb[i + 1] + pb[i + 2]
        surface = pb[i + 3] > 0.5
        # Sampling noise of the sun's disk makes a few ratios stray outside [0, 1].
        ratio = (pa[i] + pa[i + 1] + pa[i + 2]) / open_sum if open_sum > 0 else float("nan")
        fraction[i] = min(1.0, max(0.0, ratio)) if open_sum > 0 else float("nan")
        fraction[i + 1] = 1.0 if surface else 0.0
        fraction[i + 3] = 1.0
    result = bpy.data.images.new(name + "_sun", WIDTH, HEIGHT, alpha=True, float_buffer=True)
    result.pixels = fraction
    result.filepath_raw = os.path.join(out, name + "_sun.exr")
    result.file_format = "OPEN_EXR"
    result.save()
    bpy.data.images.remove(a_img)
    bpy.data.images.remove(b_img)
    os.remove(path_shadowed)
    os.remove(path_open)

common.write_objs(out, "courtyard")

with open(os.path.join(out, "camera.json"), "w") as f:
    json.dump({"position_m": CAMERA, "look_at_m": LOOK_AT, "horizontal_fov_deg": HFOV_DEG, "width": WIDTH,
               "height": HEIGHT, "bounces": bounces, "samples": samples, "sun_w_m2": SUN_W_M2, "sky": SKY, "base_ev": BASE_EV, "seed": seed,
               "blender": bpy.app.version_string}, f, indent=1)
print("render_courtyard: wrote", out)
