#!/usr/bin/env python3
"""A worked example of the relume Python module (docs/python.md).

    PYTHONPATH=build/release/python python3 python/examples/example.py SESSION OUT_DIR

SESSION: a session recorded with `relume capture`, e.g.
    build/release/apps/relume/relume capture --rig tests/data/rigs/sim-tiny-irm.yaml --out /tmp/s
It prints the session's frames with their sun, the sun over the session's day, merges a synthetic
bracket into radiance, and relights the session's first bracket to the second's light with IRM.
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


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
