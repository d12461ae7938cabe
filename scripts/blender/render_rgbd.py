"""An RGB-D recording rendered by Blender Cycles: the spherical-harmonics pipeline's test data
from a renderer that is not relume (the scene of tests/data/scenes/sh-moving-light.yaml).

    blender -b --factory-startup -noaudio -P scripts/blender/render_rgbd.py -- OUT [--frames N]
        [--bounces N] [--samples N]

Three Lambertian objects float in front of the camera with nothing else in the scene (every
surface pixel is an object, every other pixel the sky), lit by a uniform sky over the full
sphere and two distant lights (Blender sun lamps): a fill that stays put and a key that circles
the vertical axis once over the recording (360/N degrees a frame; N = 12 by default). Writes
into OUT:
  rgbd/rgb/0000.png ...    the colour frames: 8-bit sRGB through Blender's Standard view at one
                           exposure (EXPOSURE_EV, camera.json) for all frames, no dither
  rgbd/depth/0000.png ...  the depth frames: 16-bit single-channel PNG, millimetres along the
                           optical axis (planar z, not the ray's length), rounded; 0 where no
                           surface. From Cycles' Z pass, which Blender 3.4 writes as planar depth
                           for a perspective camera, 1e10 where no surface (checked against ray
                           casts of the analytic spheres and box: within the rounding's 0.5 mm
                           but for the spheres' outermost pixels, up to 1.6 mm at incidence over
                           87 deg; the ray's length differs from it by up to 2 cm there)
  rgbd/rgb.txt, rgbd/depth.txt   the TUM RGB-D benchmark's lists: `TIMESTAMP FILENAME`, Unix
                           seconds (UTC, 6 decimals), file names relative to rgbd/. Frame k at
                           START + k / FPS; its depth frame DEPTH_LEAD_S earlier (a real
                           sensor's streams are not simultaneous)
  truth/rgb/0000.exr ...   each frame in scene-linear radiance (W m^-2 sr^-1, float RGB),
                           rendered again with another sampling seed (the photograph's seed 1,
                           the truth's 2) so the truth does not share the photograph's noise
  truth/rgb.txt            the truths' list, with the colour frames' timestamps
  truth/normal.exr         the true per-pixel normals (the scene and camera are static: one for
                           all frames), Cycles' normal pass of frame 0's photograph through the
                           compositor: float RGB = the world-space shading normal's xyz, 0 where
                           no surface. The pass is the mean over the samples, so at silhouette
                           pixels where some samples miss the object it is shorter than unit length
                           (16 pixels at 64 samples; normalise before use), and a few (6) pixels
                           without depth have one (mask with depth > 0). Checked on the big sphere
                           against (P - centre) / r, P from the Z pass through relume's pinhole:
                           0.003 deg median, 0.01 deg at the 99th percentile, 0.17 deg at most
                           (from the rounded depth PNG: 0.03, 0.1, 0.16 deg)
  truth/sh_floor.json      the spherical-harmonics pipeline's floor: each frame relit to the last
                           with the true normals and the true light (camera.json), from the truths,
                           by the order-2 SH irradiance ratio (`sh2_true_normals`) and by the exact
                           unoccluded irradiance ratio (`exact_ratio_true_normals`: what is left is
                           interreflection, the objects' shadows on each other, sky occlusion and
                           render noise); relative RMS against the last truth after one
                           least-squares scale, per frame, with their mean and median, the
                           definition, and the checks (normals, the SH closed form against a
                           numerical projection, the truths against the photographs)
  camera.json              the camera (relume's pinhole: pixel centres at u + 0.5, cx = W / 2),
                           the exposure, the lights (the key's direction per frame), the render
                           settings
Conventions as in render_courtyard.py: Blender's world axes are the scene's (x east, y north,
z up, metres); Lambertian surfaces; a 0.01 px pixel filter (each depth and colour pixel is the
ray through its centre). 12 frames (24 renders) at 64 samples take about a minute on 2 cores;
the normal pass and the floor add a few seconds.
"""
import datetime
import json
import math
import os
import shutil
import struct
import sys
import tempfile
import zlib

import bpy
import mathutils
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (scripts/blender/common.py)

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
usage = "usage: blender -b -P render_rgbd.py -- OUT [--frames N] [--bounces N] [--samples N]"
options = {"--frames": 12, "--bounces": 3, "--samples": 64}
for flag in options:
    if flag in argv:
        i = argv.index(flag)
        options[flag] = int(argv[i + 1])
        del argv[i:i + 2]
if len(argv) != 1 or options["--frames"] < 1:
    sys.exit(usage)
out = argv[0]
frames, bounces, samples = options["--frames"], options["--bounces"], options["--samples"]

WIDTH, HEIGHT, HFOV_DEG = 320, 240, 58.0
CAMERA = (0.0, -1.3, 1.35)
LOOK_AT = (0.0, 0.0, 0.98)
CENTER = (0.0, 0.0, 1.0)  # where the lights' directions are taken from (the big sphere's centre)
SKY = (0.05, 0.05, 0.055)  # uniform sky radiance over the full sphere, W m^-2 sr^-1
# The lamps of sh-moving-light.yaml (point lamps ~120 m away) as distant lights: the key's
# direction at frame 0 and the fill's are toward the lamps' positions from CENTER, and their
# irradiance at normal incidence is the point lamp's I / d^2 at that distance.
KEY_POSITION, KEY_INTENSITY_W_SR = (-60.0, -80.0, 71.0), (2400.0, 2320.0, 2160.0)
FILL_POSITION, FILL_INTENSITY_W_SR = (90.0, -60.0, 41.0), (500.0, 515.0, 570.0)
LAMP_ANGLE_DEG = 0.5  # the sun lamps' angular diameter
OBJECTS = [  # (name, kind, centre, size: radius or edge, yaw deg, albedo)
    ("big-sphere", "sphere", (0.0, 0.0, 1.0), 0.25, 0.0, (0.75, 0.55, 0.45)),
    ("small-sphere", "sphere", (-0.4, -0.1, 0.95), 0.1, 0.0, (0.2, 0.35, 0.75)),
    ("box", "box", (0.42, -0.05, 1.0), 0.16, 30.0, (0.3, 0.6, 0.25)),
]
START = datetime.datetime(2026, 3, 20, 11, 0, 0, tzinfo=datetime.timezone.utc)
FPS = 30.0
DEPTH_LEAD_S = 0.002  # each depth frame is stamped this much before its colour frame
PHOTO_SEED, TRUTH_SEED = 1, 2
# The photographs' exposure (Blender's view exposure, EV; the same for every frame): the largest
# radiance any object can have, albedo * (E_key + E_fill + pi * sky) / pi per channel (both lamps
# at normal incidence and the whole sky hemisphere, an upper bound), times 2^EV is at most
# TARGET_LINEAR (sRGB 0.88 of white); EV in steps of 1/3.
TARGET_LINEAR = 0.75


def irradiance(position, intensity):
    """The direction (unit, from CENTER) and the normal-incidence irradiance (W m^-2 per channel)
    of a point lamp seen from CENTER, as a distant light."""
    v = mathutils.Vector(position) - mathutils.Vector(CENTER)
    return v.normalized(), tuple(i / v.length_squared for i in intensity)


key_direction0, KEY_E = irradiance(KEY_POSITION, KEY_INTENSITY_W_SR)
fill_direction, FILL_E = irradiance(FILL_POSITION, FILL_INTENSITY_W_SR)
bound = max(albedo[c] * (KEY_E[c] + FILL_E[c] + math.pi * SKY[c]) / math.pi
            for _, _, _, _, _, albedo in OBJECTS for c in range(3))
EXPOSURE_EV = math.floor(3.0 * math.log2(TARGET_LINEAR / bound)) / 3.0


def key_direction(k):
    """The key light's direction (unit, toward the light) at frame k: frame 0's turned by
    k * 360 / frames degrees about +z (counter-clockwise seen from above)."""
    return mathutils.Matrix.Rotation(2.0 * math.pi * k / frames, 3, "Z") @ key_direction0


def azimuth_elevation(d):
    """Azimuth (degrees from north toward east) and elevation (degrees) of a direction."""
    return math.degrees(math.atan2(d.x, d.y)) % 360.0, math.degrees(math.asin(max(-1.0, min(1.0, d.z))))


def write_png16(path, values):
    """A 16-bit greyscale PNG of `values` (rows top to bottom), written byte for byte: no
    colour management on the way."""
    height, width = values.shape
    rows = np.ascontiguousarray(values, dtype=">u2").view(np.uint8).reshape(height, width * 2)
    raw = np.hstack([np.zeros((height, 1), np.uint8), rows]).tobytes()  # filter type 0 per row

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 6)))
        f.write(chunk(b"IEND", b""))


def sun(name, direction, e):
    """A sun lamp shining from `direction` with normal-incidence irradiance `e` (per channel):
    the colour is e over its largest channel, the strength (W m^-2) that largest channel."""
    data = bpy.data.lights.new(name, "SUN")
    data.angle = math.radians(LAMP_ANGLE_DEG)
    strength = max(e)
    data.color = tuple(c / strength for c in e)
    data.energy = strength
    o = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(o)
    aim(o, direction)
    return o


def aim(lamp, direction):
    lamp.rotation_euler = direction.to_track_quat("Z", "Y").to_euler()  # the lamp shines along its -Z


def read_image(path):
    """An image file's pixels as float64 (HEIGHT, WIDTH, channels), rows top to bottom, as
    stored: no colour management on the way (Non-Color; a PNG's codes come as code / 255)."""
    image = bpy.data.images.load(path, check_existing=False)
    image.colorspace_settings.name = "Non-Color"
    buf = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(buf)
    channels = image.channels
    bpy.data.images.remove(image)
    return buf.astype(np.float64).reshape(HEIGHT, WIDTH, channels)[::-1]


def read_z(depth_exr):
    """The last render's Z pass in metres (rows top to bottom), 0 where no surface."""
    z = read_image(depth_exr)[:, :, 0]
    os.remove(depth_exr)
    return np.where(np.isfinite(z) & (z > 0.0) & (z < 1e3), z, 0.0)


def depth_mm(z):
    """Metres to the depth PNG's millimetres, rounded."""
    return np.clip(np.rint(z * 1000.0), 0, 65535).astype(np.uint16)


def stamp(seconds):
    return "%.6f" % (START.timestamp() + seconds)


def main():
    for sub in ("rgbd/rgb", "rgbd/depth", "truth/rgb"):
        os.makedirs(os.path.join(out, sub), exist_ok=True)

    scene = bpy.context.scene
    common.clear_scene()
    for name, kind, center, size, yaw, albedo in OBJECTS:
        if kind == "sphere":
            common.sphere(name, center, size, albedo)
        else:
            common.box(name, center, (size, size, size), albedo).rotation_euler = (0.0, 0.0, math.radians(yaw))
    common.camera(CAMERA, LOOK_AT, math.radians(HFOV_DEG), WIDTH, HEIGHT)

    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*SKY, 1.0)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world

    key = sun("key", key_direction(0), KEY_E)
    sun("fill", fill_direction, FILL_E)

    common.cycles(samples, bounces)
    scene.render.film_transparent = False
    scene.render.dither_intensity = 0.0  # the 8-bit frames quantise the view's output, no noise added

    # The Z and normal passes through the compositor into float EXRs (the render result's passes
    # cannot be read from Python): Render Layers' Depth and Normal into a File Output node (a file
    # per pass), the image straight to Composite. Cycles' normal pass is the shading normal in
    # world coordinates, 0 where no surface.
    scene.view_layers[0].use_pass_z = True
    scene.view_layers[0].use_pass_normal = True
    scene.use_nodes = True
    tree = scene.node_tree
    for node in list(tree.nodes):
        tree.nodes.remove(node)
    layers = tree.nodes.new("CompositorNodeRLayers")
    composite = tree.nodes.new("CompositorNodeComposite")
    tree.links.new(layers.outputs["Image"], composite.inputs["Image"])
    depth_dir = tempfile.mkdtemp(prefix="render_rgbd-")
    depth_out = tree.nodes.new("CompositorNodeOutputFile")
    depth_out.base_path = depth_dir
    depth_out.format.file_format = "OPEN_EXR"
    depth_out.format.color_depth = "32"
    depth_out.format.color_mode = "RGB"
    depth_out.format.exr_codec = "ZIP"
    depth_out.file_slots[0].path = "depth"
    tree.links.new(layers.outputs["Depth"], depth_out.inputs[0])
    depth_out.file_slots.new("normal")
    tree.links.new(layers.outputs["Normal"], depth_out.inputs[1])
    depth_exr = os.path.join(depth_dir, "depth%04d.exr" % scene.frame_current)
    normal_exr = os.path.join(depth_dir, "normal%04d.exr" % scene.frame_current)
    try:
        z = record(scene, key, depth_exr, normal_exr)
    finally:
        shutil.rmtree(depth_dir, ignore_errors=True)
    if frames > 1:
        sh_floor(z)


def record(scene, key, depth_exr, normal_exr):
    """Renders the frames and writes the lists, truth/normal.exr and camera.json. Returns the
    depth in metres (frame 0's Z pass; the scene and the camera are static)."""
    rgb_list = ["# colour images (Blender Cycles, scripts/blender/render_rgbd.py): 8-bit sRGB PNG at EV %+g"
                % EXPOSURE_EV, "# timestamp filename"]
    depth_list = ["# depth maps (Blender Cycles, scripts/blender/render_rgbd.py): 16-bit PNG, millimetres along the"
                  " optical axis, 0 = no surface", "# timestamp filename"]
    truth_list = ["# scene-linear truths (Blender Cycles, another sampling seed): float RGB EXR, W m^-2 sr^-1",
                  "# timestamp filename"]
    keys = []
    for k in range(frames):
        d = key_direction(k)
        aim(key, d)
        az, el = azimuth_elevation(d)
        keys.append({"frame": k, "direction": [round(c, 9) for c in d], "azimuth_deg": round(az, 6),
                     "elevation_deg": round(el, 6)})
        name = "%04d" % k
        # The photograph and its depth: seed 1, the compositor on (the depth EXR).
        scene.cycles.seed = PHOTO_SEED
        scene.render.use_compositing = True
        bpy.ops.render.render()
        common.save_render(os.path.join(out, "rgbd", "rgb", name + ".png"), "PNG", "8", exposure=EXPOSURE_EV)
        z = read_z(depth_exr)
        if k == 0:  # the scene is static: the normals of the first frame's render are every frame's
            z0 = z
            shutil.move(normal_exr, os.path.join(out, "truth", "normal.exr"))
        else:
            os.remove(normal_exr)
        write_png16(os.path.join(out, "rgbd", "depth", name + ".png"), depth_mm(z))
        # The truth: the same frame with seed 2, scene-linear.
        scene.cycles.seed = TRUTH_SEED
        scene.render.use_compositing = False
        bpy.ops.render.render()
        common.save_render(os.path.join(out, "truth", "rgb", name + ".exr"), "OPEN_EXR", "32")
        t = k / FPS
        rgb_list.append("%s rgb/%s.png" % (stamp(t), name))
        depth_list.append("%s depth/%s.png" % (stamp(t - DEPTH_LEAD_S), name))
        truth_list.append("%s rgb/%s.exr" % (stamp(t), name))
        print("render_rgbd: frame %d of %d, key light at azimuth %.1f, elevation %.1f deg" % (k + 1, frames, az, el))

    for path, lines in ((os.path.join(out, "rgbd", "rgb.txt"), rgb_list),
                        (os.path.join(out, "rgbd", "depth.txt"), depth_list),
                        (os.path.join(out, "truth", "rgb.txt"), truth_list)):
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")

    fx = (WIDTH / 2.0) / math.tan(math.radians(HFOV_DEG) / 2.0)
    fill_az, fill_el = azimuth_elevation(fill_direction)
    with open(os.path.join(out, "camera.json"), "w") as f:
        json.dump({"width": WIDTH, "height": HEIGHT, "fx": fx, "fy": fx, "cx": WIDTH / 2.0, "cy": HEIGHT / 2.0,
                   "horizontal_fov_deg": HFOV_DEG, "position_m": CAMERA, "look_at_m": LOOK_AT, "up": [0.0, 0.0, 1.0],
                   "exposure_ev": EXPOSURE_EV, "frames": frames, "fps": FPS, "start_utc": START.isoformat(),
                   "depth_lead_s": DEPTH_LEAD_S, "depth_unit": "mm along the optical axis, 0 = no surface",
                   "key_light": {"irradiance_w_m2": KEY_E, "angle_deg": LAMP_ANGLE_DEG, "directions": keys},
                   "fill_light": {"irradiance_w_m2": FILL_E, "angle_deg": LAMP_ANGLE_DEG,
                                  "direction": [round(c, 9) for c in fill_direction],
                                  "azimuth_deg": round(fill_az, 6), "elevation_deg": round(fill_el, 6)},
                   "sky_radiance": SKY, "objects": [{"name": n, "kind": kd, "center_m": c, "size_m": s, "yaw_deg": y,
                                                     "albedo": a} for n, kd, c, s, y, a in OBJECTS],
                   "bounces": bounces, "samples": samples, "seeds": {"rgb": PHOTO_SEED, "truth": TRUTH_SEED},
                   "blender": bpy.app.version_string}, f, indent=1)
    return z0


# The order-2 spherical-harmonics floor: what relume's SH pipeline (order-2 lighting per frame,
# relit_k = photo_k * E_sh_dst(n) / E_sh_src(n)) could do at best, with the true normals and the
# true light. Real orthonormal SH; irradiance of radiance L_lm is sum_l A_l sum_m L_lm Y_lm(n)
# (Ramamoorthi & Hanrahan 2001).
SH_A = np.array([math.pi] + [2.0 * math.pi / 3.0] * 3 + [math.pi / 4.0] * 5)
GUARD = 0.05  # a pixel is relit where the source irradiance exceeds GUARD times its object mean


def sh9(n):
    """The 9 real orthonormal SH of order <= 2 at unit directions n (..., 3) -> (..., 9)."""
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    return np.stack([np.full_like(x, 0.282094791773878), 0.488602511902920 * y, 0.488602511902920 * z,
                     0.488602511902920 * x, 1.092548430592079 * x * y, 1.092548430592079 * y * z,
                     0.315391565252520 * (3.0 * z * z - 1.0), 1.092548430592079 * x * z,
                     0.546274215296040 * (x * x - y * y)], axis=-1)


def light_sh(k):
    """Frame k's radiance SH coefficients (9, 3): both distant lights as deltas and the sky."""
    coefficients = (sh9(np.array(key_direction(k)))[:, None] * np.array(KEY_E)
                    + sh9(np.array(fill_direction))[:, None] * np.array(FILL_E))
    coefficients[0] += np.array(SKY) * math.sqrt(4.0 * math.pi)
    return coefficients


def irradiance_sh2(k, n):
    """The order-2 SH irradiance of frame k's light at normals n (M, 3) -> (M, 3)."""
    return sh9(n) @ (SH_A[:, None] * light_sh(k))


def irradiance_exact(k, n):
    """Frame k's unoccluded irradiance at normals n (M, 3) -> (M, 3): both lamps' cosines and
    the full-sphere sky's pi * s."""
    cos_key = np.maximum(0.0, n @ np.array(key_direction(k)))
    cos_fill = np.maximum(0.0, n @ np.array(fill_direction))
    return cos_key[:, None] * np.array(KEY_E) + cos_fill[:, None] * np.array(FILL_E) + math.pi * np.array(SKY)


def sh_closed_form_check():
    """The closed form against a direct numerical projection: max(0, n.l) projected on Y_lm over
    a fine (theta, phi) grid and reconstructed at a few normals, for a few l. Returns the largest
    difference (a light of unit irradiance) and E2(l) / E for one light."""
    count = 1000
    theta = (np.arange(count) + 0.5) * math.pi / count
    phi = (np.arange(2 * count) + 0.5) * math.pi / count
    t, p = np.meshgrid(theta, phi, indexing="ij")
    w = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    dw = (np.sin(t) * (math.pi / count) ** 2).reshape(-1)
    basis = sh9(w)
    rng = np.random.default_rng(7)
    normals = rng.normal(size=(20, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    largest = 0.0
    for l in (np.array(key_direction0), np.array(fill_direction), np.array([0.0, 0.0, 1.0])):
        numeric = (basis * (np.maximum(0.0, w @ l) * dw)[:, None]).sum(axis=0)
        n = np.vstack([normals, l, -l])
        largest = max(largest, float(np.abs(sh9(n) @ numeric - sh9(n) @ (SH_A * sh9(l))).max()))
    peak = float(sh9(np.array([0.0, 0.0, 1.0])) @ (SH_A * sh9(np.array([0.0, 0.0, 1.0]))))
    return largest, peak


def pixel_points(z):
    """The surface points (HEIGHT, WIDTH, 3) of planar depth z through relume's pinhole (pixel
    centres at u + 0.5, cx = W / 2, cy = H / 2, x right, y down, z along the optical axis)."""
    fx = (WIDTH / 2.0) / math.tan(math.radians(HFOV_DEG) / 2.0)
    forward = (mathutils.Vector(LOOK_AT) - mathutils.Vector(CAMERA)).normalized()
    right = forward.cross(mathutils.Vector((0.0, 0.0, 1.0))).normalized()
    down = right.cross(forward) * -1.0
    u = (np.arange(WIDTH) + 0.5 - WIDTH / 2.0) / fx
    v = (np.arange(HEIGHT) + 0.5 - HEIGHT / 2.0) / fx
    x, y = u[None, :] * z, v[:, None] * z
    return (np.array(CAMERA) + x[..., None] * np.array(right) + y[..., None] * np.array(down)
            + z[..., None] * np.array(forward))


def normal_check(z, mm, normals):
    """The normal pass on the big sphere against (P - centre) / r of the points P from the depth:
    angle errors (degrees) at a few pixels, and their spread over all the sphere's pixels."""
    name, _, center, radius, _, _ = OBJECTS[0]
    result = {"object": name}
    for label, depth in (("float_z", z), ("depth_png_mm", mm / 1000.0)):
        points = pixel_points(depth)
        radial = (points - np.array(center)) / radius
        on = (depth > 0) & (np.abs(np.linalg.norm(radial, axis=-1) - 1.0) < 0.02)
        cosine = (normals * radial).sum(-1) / np.maximum(1e-12, np.linalg.norm(normals, axis=-1)
                                                         * np.linalg.norm(radial, axis=-1))
        angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
        rows, cols = np.nonzero(on)
        r0, c0 = int(np.rint(rows.mean())), int(np.rint(cols.mean()))
        picks = [(r0, c0), (r0 - 20, c0), (r0 + 20, c0 + 20), (r0, c0 - 30), (r0 - 30, c0 + 25)]
        result[label] = {
            "pixels": [{"row": r, "col": c, "angle_deg": round(float(angle[r, c]), 4),
                        "normal": [round(float(a), 5) for a in normals[r, c]],
                        "radial": [round(float(a), 5) for a in radial[r, c]]} for r, c in picks if on[r, c]],
            "sphere_pixels": int(on.sum()), "median_deg": round(float(np.median(angle[on])), 4),
            "p99_deg": round(float(np.percentile(angle[on], 99)), 4), "max_deg": round(float(angle[on].max()), 4)}
    return result


def relative_rms(relit, truth):
    """Relative RMS after one least-squares scale over all channels and pixels."""
    a = (relit * truth).sum() / (relit * relit).sum()
    return float(np.sqrt(((a * relit - truth) ** 2).sum() / (truth * truth).sum()))


def sh_floor(z):
    """truth/sh_floor.json: every frame relit to the last with the true normals and the true light,
    by the order-2 SH irradiance ratio and by the exact (unoccluded) ratio, against the last truth."""
    mm = depth_mm(z)
    normal_image = read_image(os.path.join(out, "truth", "normal.exr"))[:, :, :3]
    mask = mm > 0
    lengths = np.linalg.norm(normal_image, axis=-1)
    mask_check = {"object_pixels": int(mask.sum()), "object_pixels_without_normal": int((mask & (lengths < 0.5)).sum()),
                  "sky_pixels_with_normal": int((~mask & (lengths > 0.0)).sum()),
                  "normal_length_min": round(float(lengths[mask].min()), 6),
                  "normal_length_max": round(float(lengths[mask].max()), 6)}
    normals = normal_image[mask] / np.maximum(1e-12, lengths[mask])[:, None]
    truths = [read_image(os.path.join(out, "truth", "rgb", "%04d.exr" % k))[:, :, :3] for k in range(frames)]
    # The truths load linear: the last one through the photographs' view (EV, sRGB) against its PNG.
    photo = read_image(os.path.join(out, "rgbd", "rgb", "%04d.png" % (frames - 1)))[:, :, :3] * 255.0
    linear = np.clip(truths[-1] * 2.0 ** EXPOSURE_EV, 0.0, 1.0)
    view = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1.0 / 2.4) - 0.055) * 255.0
    png_check = {"frame": frames - 1, "mean_difference_codes": round(float((view - photo)[mask].mean()), 4),
                 "rms_difference_codes": round(float(np.sqrt(((view - photo)[mask] ** 2).mean())), 4)}
    d = frames - 1
    e2_d, e_d = irradiance_sh2(d, normals), irradiance_exact(d, normals)
    truth_d = truths[d][mask]
    rows = []
    for k in range(d):
        e2_k, e_k = irradiance_sh2(k, normals), irradiance_exact(k, normals)
        relit = (e2_k > GUARD * e2_k.mean(axis=0)).all(axis=1) & (e_k > GUARD * e_k.mean(axis=0)).all(axis=1)
        truth_k = truths[k][mask][relit]
        rows.append({"frame": k, "timestamp": stamp(k / FPS),
                     "sh2_true_normals": relative_rms(truth_k * e2_d[relit] / e2_k[relit], truth_d[relit]),
                     "exact_ratio_true_normals": relative_rms(truth_k * e_d[relit] / e_k[relit], truth_d[relit]),
                     "relit_pixels": int(relit.sum())})
        print("render_rgbd: floor frame %d -> %d: sh2 %.2f %%, exact %.2f %% over %d pixels"
              % (k, d, 100 * rows[-1]["sh2_true_normals"], 100 * rows[-1]["exact_ratio_true_normals"],
                 rows[-1]["relit_pixels"]))
    sh2 = [r["sh2_true_normals"] for r in rows]
    largest, peak = sh_closed_form_check()
    checks = {"normals": normal_check(z, mm, normal_image), "normal_mask": mask_check,
              "truth_vs_photograph": png_check,
              "sh_closed_form_vs_numerical_projection_max_abs": largest, "sh2_at_light_over_E": peak}
    with open(os.path.join(out, "truth", "sh_floor.json"), "w") as f:
        json.dump({"destination_frame": d, "destination_timestamp": stamp(d / FPS), "definition": (
            "Each frame k relit to the last frame d with the true per-pixel normals n (truth/normal.exr) and "
            "the true light (camera.json), from truth/rgb/k.exr: relit = truth_k * E_d(n) / E_k(n) per channel, "
            "with E2 the order-2 SH irradiance (radiance coefficients L_lm = E_key Y_lm(l_k) + E_fill Y_lm(l_f) "
            "+ sky sqrt(4 pi) [l = 0]; E2(n) = sum_l A_l sum_m L_lm Y_lm(n), A = pi, 2 pi / 3, pi / 4; real "
            "orthonormal SH) for sh2_true_normals and the exact unoccluded irradiance E(n) = E_key max(0, n.l_k) "
            "+ E_fill max(0, n.l_f) + pi sky for exact_ratio_true_normals. Over object pixels (depth > 0) where "
            "every channel of E2_k and of E_k exceeds %g times its mean over the object pixels (the same pixels "
            "for both). Error: relative RMS against truth_d with one least-squares scale a = sum(r t) / sum(r r) "
            "over all channels and pixels, sqrt(sum((a r - t)^2) / sum(t^2))." % GUARD),
            "frames": rows, "median_sh2_true_normals": float(np.median(sh2)), "mean_sh2_true_normals": float(np.mean(sh2)),
            "mean_exact_ratio_true_normals": float(np.mean([r["exact_ratio_true_normals"] for r in rows])),
            "checks": checks}, f, indent=1)
    print("render_rgbd: checks", json.dumps(checks))


try:
    main()
except Exception:  # Blender exits 0 after an uncaught error in a -P script; the caller needs 1
    import traceback
    traceback.print_exc()
    sys.exit(1)
print("render_rgbd: wrote", out)
