#!/usr/bin/env python3
"""A worked example of the relume Python module (docs/python.md).

    PYTHONPATH=build/release/python python3 python/examples/example.py SESSION OUT_DIR

SESSION: a session recorded with `relume capture`, e.g.
    build/release/apps/relume/relume capture --rig tests/data/rigs/sim-tiny-irm.yaml --out /tmp/s
It prints the session's frames with their sun, the sun over the session's day, merges a synthetic
bracket into radiance, relights the session's first bracket to the second's light with IRM through
the pipeline, and then again step by step from arrays (the same pixels), and finds a plane's
normals from a depth map.
"""
import sys

import numpy as np

import relume


def main(session_dir, out_dir):
    # 1. A recorded session: frames as dicts, pixels as numpy arrays.
    session = relume.Session(session_dir)
    site = session.info["site"]
    print(f"session {session.info['name']} at {site['lat_deg']:.4f} N, {site['lon_deg']:.4f} E")
    for frame in session.frames:
        print(f"  frame {frame['id']} {frame['device']} {frame['utc']} bracket {frame['bracket_id']} "
              f"t={frame['exposure_time_s']:.4g} s  sun elevation {frame['sun_elevation_deg']:.3f} deg")
    pixels = session.load_image(session.frames[0]["id"])
    print(f"  first frame: {pixels.dtype} {pixels.shape}, {session.frames[0]['layout']}")

    # 2. The sun over the first frame's day, every minute, in one vectorised call.
    day_start = np.floor(session.frames[0]["unix_seconds"] / 86400.0) * 86400.0
    times = day_start + np.arange(0.0, 86400.0, 60.0)
    elevation, azimuth = relume.sun_positions(times, site["lat_deg"], site["lon_deg"], site["height_m"])
    noon = int(np.argmax(elevation))
    print(f"sun: highest {elevation[noon]:.3f} deg at azimuth {azimuth[noon]:.2f} deg, "
          f"above the horizon {np.count_nonzero(elevation > 0) / 60:.1f} h of the day")

    # 3. HDR from arrays: a synthetic 3-frame bracket of a gamma-2.2 camera.
    radiance_truth = np.geomspace(0.01, 10.0, 256 * 64).reshape(64, 256, 1) * np.array([1.0, 0.9, 0.7])
    exposures_s = [1 / 16, 1 / 4, 1.0]
    frames = [(255.0 * np.clip(radiance_truth * t, 0.0, 1.0) ** (1 / 2.2)).round().astype(np.uint8)
              for t in exposures_s]
    response, summary = relume.recover_response(frames, exposures_s)
    radiance = relume.merge_hdr(frames, exposures_s, response)
    print(f"response: {summary['brief']}")
    print(f"radiance: {radiance.dtype} {radiance.shape}, dynamic range {radiance.max() / radiance.min():.0f}:1")

    # 4. A pipeline, as `relume process SESSION --pipeline irm --source bracket:1 --target bracket:2`.
    result = relume.process(session_dir, "irm", source="bracket:1", target="bracket:2", out_dir=out_dir,
                            settings={"bins": 32})
    irm = result["pipelines"]["irm"]["summary"]
    print(f"irm: {irm['headline']}")
    print(f"report: {result['report']}")

    # 5. The same relighting step by step from arrays: merge each bracket, take the camera and the
    #    geometry from the session's scene model, the sun of each bracket's first frame, and relight.
    views = []
    for bracket_id in (1, 2):
        frames = [f for f in session.frames if f["bracket_id"] == bracket_id]
        first = frames[0]
        exposures = [f["exposure_time_s"] * f["iso"] / 100.0 for f in frames]  # the pipelines' t * ISO / 100
        bracket_radiance, status, _, _ = relume.merge_hdr(
            [session.load_image(f["id"]) for f in frames], exposures, "linear", black_level=first["black_level"],
            white_level=first["white_level"], bits_per_sample=first["bits_per_sample"], full_output=True)
        views.append({"radiance": bracket_radiance, "mask": status != 0, "camera": session.camera(first["device"]),
                      "sun": relume.enu_direction(first["sun_azimuth_deg"], first["sun_elevation_deg"])})
    source, target = views
    relit = relume.irm_relight(session.scene_mesh(spacing_m=0.5), source["radiance"], target["radiance"],
                               source["camera"], target["camera"], source["sun"], target["sun"],
                               source_mask=source["mask"], target_mask=target["mask"], bins=32)
    pipeline_relit = relume.load_radiance_exr(
        f"{out_dir}/" + next(o["path"] for o in irm["outputs"] if o["path"].endswith("relit.exr")))
    same = np.array_equal(relit["relit"], pipeline_relit, equal_nan=True)
    print(f"irm from arrays: {relit['summary']['pixels_relit']} pixels relit, "
          f"{'the same as' if same else 'DIFFERENT from'} the pipeline's relit.exr")

    # 6. Normals from depth: a plane 2 m away, tilted, seen by a 160x120 camera.
    k = {"width": 160, "height": 120, "fx": 150.0, "fy": 150.0, "cx": 80.0, "cy": 60.0}
    u, v = np.meshgrid(np.arange(160) + 0.5, np.arange(120) + 0.5)
    plane_normal = np.array([0.3, 0.0, -1.0]) / np.hypot(0.3, 1.0)
    rays = np.stack([(u - k["cx"]) / k["fx"], (v - k["cy"]) / k["fy"], np.ones_like(u)], axis=-1)
    depth_m = (-2.0 / (rays @ plane_normal)).astype(np.float32)
    normals = relume.estimate_normals(depth_m, k)
    error_deg = np.degrees(np.arccos(np.clip(normals["normals"][normals["valid"]] @ plane_normal, -1, 1))).max()
    print(f"normals: {normals['valid'].sum()} valid, at most {error_deg:.4f} deg from the plane's")
    #    With Kinect-like noise (1.5 mm at 1 m, growing as z^2), the bilateral filter's effect on it.
    noisy_m = (depth_m + np.random.default_rng(1).normal(0.0, 0.0015, depth_m.shape) * depth_m**2).astype(np.float32)
    before = relume.estimate_depth_noise(noisy_m)["sigma_at_1m_m"]
    after = relume.estimate_depth_noise(relume.bilateral_filter_depth(noisy_m))["sigma_at_1m_m"]
    print(f"depth noise at 1 m: {1e3 * before:.2f} mm, {1e3 * after:.2f} mm after the bilateral filter")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
