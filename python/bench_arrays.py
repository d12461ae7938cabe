#!/usr/bin/env python3
"""Times the array bindings from Python and what the binding itself costs: each call's wall time
beside the time the library reports for its own work (where it reports one), and C-contiguous
input (read in place) against a strided view of the same pixels (copied once). A benchmark, not
a test: it prints, it asserts nothing.

    PYTHONPATH=build/release/python python3 python/bench_arrays.py [SESSION]

SESSION: a session of tests/data/rigs/sim-tiny-irm.yaml (`relume capture`) for the IRM timing.
"""
import sys
import time

import numpy as np

import relume


def best(call, repeats=5):
    """The fastest of `repeats` calls: its time and its result."""
    fastest, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        value = call()
        elapsed = time.perf_counter() - start
        if elapsed < fastest:
            fastest, result = elapsed, value
    return fastest, result


def main():
    width, height = 640, 480
    k = {"width": width, "height": height, "fx": 525.0, "fy": 525.0, "cx": 320.0, "cy": 240.0}
    u, v = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    normal = np.array([0.2, -0.1, -1.0]) / np.linalg.norm([0.2, -0.1, -1.0])
    rays = np.stack([(u - k["cx"]) / k["fx"], (v - k["cy"]) / k["fy"], np.ones_like(u)], axis=-1)
    depth = (-1.5 / (rays @ normal)).astype(np.float32)
    depth += np.random.default_rng(1).normal(0, 0.002, depth.shape).astype(np.float32)
    wide = np.zeros((height, 2 * width), np.float32)
    wide[:, ::2] = depth
    strided = wide[:, ::2]  # the same pixels, not contiguous: copied once by the binding
    print(f"{width}x{height} depth, best of 5:")
    for name, call in [("bilateral_filter_depth", lambda d: relume.bilateral_filter_depth(d)),
                       ("estimate_normals", lambda d: relume.estimate_normals(d, k))]:
        t_in_place, _ = best(lambda: call(depth))
        t_copied, _ = best(lambda: call(strided))
        print(f"  {name:24s} contiguous {1e3 * t_in_place:7.2f} ms   strided {1e3 * t_copied:7.2f} ms")
    t_copy, _ = best(lambda: np.ascontiguousarray(strided))
    print(f"  {'(numpy copy of strided)':24s} {1e3 * t_copy:7.2f} ms")

    normals = relume.estimate_normals(depth, k)["normals"]
    radiance = np.abs(normals).astype(np.float32) + 0.1
    t_fit, (light, summary) = best(lambda: relume.fit_sh(radiance, normals))
    print(f"  {'fit_sh':24s} {1e3 * t_fit:7.2f} ms ({summary['observation_count']} pixels)")
    t_relight, _ = best(lambda: relume.relight_sh(radiance, normals, light, light * 1.1))
    print(f"  {'relight_sh':24s} {1e3 * t_relight:7.2f} ms")

    if len(sys.argv) > 1:
        session = relume.Session(sys.argv[1])
        t_mesh, mesh = best(lambda: session.scene_mesh(), repeats=3)
        views = []
        for bracket in (1, 2):
            frames = [f for f in session.frames if f["bracket_id"] == bracket]
            first = frames[0]
            radiance, status, _, _ = relume.merge_hdr(
                [session.load_image(f["id"]) for f in frames],
                [f["exposure_time_s"] * (f["iso"] or 100.0) / 100.0 for f in frames], "linear",
                black_level=first["black_level"], white_level=first["white_level"],
                bits_per_sample=first["bits_per_sample"], full_output=True)
            views.append((radiance, status != 0, session.camera(first["device"]),
                          relume.enu_direction(first["sun_azimuth_deg"], first["sun_elevation_deg"])))
        (s, t) = views
        t_irm, result = best(lambda: relume.irm_relight(mesh, s[0], t[0], s[2], t[2], s[3], t[3], source_mask=s[1],
                                                        target_mask=t[1]), repeats=3)
        inside = sum(result["summary"][key] for key in ("preprocess_s", "build_s", "relight_s"))
        print(f"IRM on {sys.argv[1]} ({len(mesh['positions'])} vertices, {len(mesh['triangles'])} triangles):")
        print(f"  scene_mesh {1e3 * t_mesh:7.1f} ms; irm_relight {1e3 * t_irm:7.1f} ms, of which the library's "
              f"three steps {1e3 * inside:7.1f} ms (the rest: Embree's tree and the mesh copy)")


if __name__ == "__main__":
    main()
