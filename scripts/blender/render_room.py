"""A room lit by a point lamp, rendered by Blender Cycles with interreflection: the radiosity
pipeline's test data from a renderer that is not relume.

Run by scripts/blender_room_dataset.sh:
    blender -b --factory-startup -P scripts/blender/render_room.py -- OUT [--samples N] [--bounces N]

The room is 6 x 5 x 3 m (origin at the floor's centre, x east, y north, z up) with a desk, a
cabinet and a grey-scale chart on a stand (six 20 cm patches of known albedo, the ColorChecker's
neutral row, in a black frame), every surface Lambertian. One point lamp of 30 W/sr (Blender:
30 * 4 pi W) hangs at LAMP_A for the first photograph and at LAMP_B for the second; a third
render puts it at RELIGHT (the radiosity pipeline's default relighting lamp). Writes into OUT:
  a.exr, b.exr            the photographs, scene-linear radiance (W m^-2 sr^-1)
  a_ev-2.jpg .. a_ev+2.jpg, b_...   five-frame brackets through Blender's sRGB view about BASE_EV
  relit.exr, relit.json   the view under the relighting lamp, and that lamp
  albedo.json             every material's true albedo (the chart's too)
  room_<object>.obj       the geometry (the chart with one `usemtl` per patch)
  camera.json             the camera
"""
import json
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not argv:
    sys.exit("usage: blender -b -P render_room.py -- OUT [--samples N] [--bounces N]")
out = argv[0]
samples = int(argv[argv.index("--samples") + 1]) if "--samples" in argv else 64
bounces = int(argv[argv.index("--bounces") + 1]) if "--bounces" in argv else 8
os.makedirs(out, exist_ok=True)

WIDTH, HEIGHT, HFOV_DEG = 240, 180, 75.0
CAMERA = (-2.7, -2.2, 1.7)
LOOK_AT = (0.6, 1.2, 0.8)
INTENSITY_W_SR = 30.0
LAMP_A = (0.0, 0.0, 1.9)
LAMP_B = (1.6, 1.2, 2.3)
RELIGHT = (1.0, -1.0, 2.2)
BASE_EV = -3.0
BRACKET_EV = (-2, -1, 0, 1, 2)

albedo = {
    "floor": (0.35, 0.28, 0.20),
    "ceiling": (0.85, 0.85, 0.85),
    "wall-west": (0.75, 0.72, 0.65),
    "wall-east": (0.75, 0.72, 0.65),
    "wall-south": (0.60, 0.68, 0.75),
    "wall-north": (0.60, 0.68, 0.75),
    "desk-top": (0.50, 0.33, 0.20),
    "desk-leg-west": (0.20, 0.20, 0.20),
    "desk-leg-east": (0.20, 0.20, 0.20),
    "cabinet": (0.62, 0.60, 0.55),
    "chart-stand": (0.15, 0.15, 0.15),
}
CHART_PATCHES = [("grey-%d" % (i + 1), (g, g, g)) for i, g in enumerate((0.90, 0.59, 0.36, 0.19, 0.09, 0.03))]
CHART_FRAME = (0.03, 0.03, 0.03)

scene = bpy.context.scene
common.clear_scene()

# The room's six faces (one-sided in relume; Blender renders both sides alike).
W, D, H = 3.0, 2.5, 3.0
corners = {
    "floor": [(-W, -D, 0), (W, -D, 0), (W, D, 0), (-W, D, 0)],
    "ceiling": [(-W, -D, H), (-W, D, H), (W, D, H), (W, -D, H)],
    "wall-west": [(-W, -D, 0), (-W, D, 0), (-W, D, H), (-W, -D, H)],
    "wall-east": [(W, -D, 0), (W, -D, H), (W, D, H), (W, D, 0)],
    "wall-south": [(-W, -D, 0), (-W, -D, H), (W, -D, H), (W, -D, 0)],
    "wall-north": [(-W, D, 0), (W, D, 0), (W, D, H), (-W, D, H)],
}
for name, quad in corners.items():
    common.mesh_object(name, quad, [(0, 1, 2, 3)], [(name, albedo[name])], [0])
common.box("desk-top", (0.6, 1.2, 0.74), (1.6, 0.8, 0.04), albedo["desk-top"])
legs = []
for x in (-0.17, 1.37):
    legs.append(common.box("desk-leg-%s" % ("west" if x < 0 else "east"), (x, 1.2, 0.36), (0.04, 0.76, 0.72),
                           albedo["desk-leg-west"]))
common.box("cabinet", (-2.4, -1.8, 0.6), (0.8, 0.5, 1.2), albedo["cabinet"])
common.box("chart-stand", (-1.26, -0.72, 0.39), (0.04, 0.04, 0.78), albedo["chart-stand"])

# The chart: a 2 x 3 grid of 20 cm patches (2 cm gaps, 3 cm border) on a 1 cm thick frame's
# front, tilted halfway between the camera and the first lamp position.
center = (-1.26, -0.72, 0.8)
normal = (0.05, -0.25, 0.97)
import mathutils  # noqa: E402
n = mathutils.Vector(normal).normalized()
u = mathutils.Vector((0.64, 0.66, 0.0))
u = (u - u.dot(n) * n).normalized()  # along the rows
v = n.cross(u)  # along the columns
P, G, B = 0.20, 0.02, 0.03
width, height = 3 * P + 2 * G + 2 * B, 2 * P + G + 2 * B
c = mathutils.Vector(center)
vertices, faces, face_materials = [], [], []


def quad(a0, b0, size_u, size_v, lift, material_index):
    base = len(vertices)
    origin = c + a0 * u + b0 * v + lift * n
    for du, dv in ((0, 0), (size_u, 0), (size_u, size_v), (0, size_v)):
        vertices.append(tuple(origin + du * u + dv * v))
    faces.append((base, base + 1, base + 2, base + 3))
    face_materials.append(material_index)


quad(-width / 2, -height / 2, width, height, 0.0, 0)  # the frame's front
for i in range(6):
    row, col = i // 3, i % 3
    quad(-width / 2 + B + col * (P + G), height / 2 - B - P - row * (P + G), P, P, 0.0005, i + 1)
chart_materials = [("chart-frame", CHART_FRAME)] + [("chart/" + name, a) for name, a in CHART_PATCHES]
# Blender material names "chart/grey-1": the OBJ's usemtl groups, which the scene file reads as
# materials "chart/<group>"; strip the object prefix there.
common.mesh_object("chart", vertices, faces, [(name.split("/")[-1], a) for name, a in chart_materials], face_materials)
for name, a in CHART_PATCHES:
    albedo["chart/" + name] = a
albedo["chart"] = CHART_FRAME

common.camera(CAMERA, LOOK_AT, math.radians(HFOV_DEG), WIDTH, HEIGHT)
world = bpy.data.worlds.new("dark")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
scene.world = world
lamp_data = bpy.data.lights.new("lamp", "POINT")
lamp_data.energy = INTENSITY_W_SR * 4.0 * math.pi  # Cycles: a point lamp of P watts has P / (4 pi) W/sr
lamp_data.shadow_soft_size = 0.0
lamp = bpy.data.objects.new("lamp", lamp_data)
scene.collection.objects.link(lamp)
common.cycles(samples, bounces)

for name, position in (("a", LAMP_A), ("b", LAMP_B), ("relit", RELIGHT)):
    lamp.location = position
    bpy.ops.render.render()
    common.save_render(os.path.join(out, name + ".exr"), "OPEN_EXR", "32")
    if name != "relit":
        for ev in BRACKET_EV:
            common.save_render(os.path.join(out, "%s_ev%+d.jpg" % (name, ev)), "JPEG", "8", exposure=BASE_EV + ev)

common.write_objs(out, "room")
with open(os.path.join(out, "relit.json"), "w") as f:
    json.dump({"light_m": RELIGHT, "light_intensity_w_sr": INTENSITY_W_SR}, f)
with open(os.path.join(out, "albedo.json"), "w") as f:
    json.dump(albedo, f, indent=1)
with open(os.path.join(out, "camera.json"), "w") as f:
    json.dump({"position_m": CAMERA, "look_at_m": LOOK_AT, "horizontal_fov_deg": HFOV_DEG, "width": WIDTH,
               "height": HEIGHT, "lamp_a_m": LAMP_A, "lamp_b_m": LAMP_B, "intensity_w_sr": INTENSITY_W_SR,
               "bounces": bounces, "samples": samples, "blender": bpy.app.version_string}, f, indent=1)
print("render_room: wrote", out)
