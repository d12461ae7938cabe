"""relume.sun_positions against `relume sun --csv` (the CLI's batch path), broadcasting, and the
series path against per-element evaluation."""
import csv
import datetime
import io

import numpy as np
import pytest

import relume

TOLERANCE_DEG = 0.0003  # issue 22: the same accuracy as `relume sun`


def iso(unix_ms):
    t = datetime.datetime.fromtimestamp(unix_ms // 1000, datetime.timezone.utc)
    return t.strftime("%Y-%m-%dT%H:%M:%S") + f".{unix_ms % 1000:03d}Z"


def angle_difference_deg(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


def test_random_times_and_sites_match_the_cli(cli):
    rng = np.random.default_rng(22)
    n = 400
    # 1900..2100 in whole milliseconds, so that the CLI reads exactly the same instant.
    unix_ms = rng.integers(-2208988800000, 4102444800000, n)
    lat = rng.uniform(-89.9, 89.9, n)
    lon = rng.uniform(-180.0, 180.0, n)
    height = rng.uniform(-100.0, 5000.0, n)
    # Half the rows without refraction (pressure 0), half with a random atmosphere; a third with a
    # given delta_t, the others with the model (an empty CSV cell = the flag's default = model).
    pressure = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(500.0, 1050.0, n))
    temperature = rng.uniform(-30.0, 40.0, n)
    given_delta_t = rng.random(n) < 0.33
    delta_t = np.where(given_delta_t, rng.uniform(-5.0, 200.0, n), np.nan)

    rows = io.StringIO()
    rows.write("time,lat,lon,height,delta_t,pressure,temperature\n")
    for i in range(n):
        dt = repr(float(delta_t[i])) if given_delta_t[i] else ""
        rows.write(f"{iso(int(unix_ms[i]))},{lat[i]!r},{lon[i]!r},{height[i]!r},{dt},{pressure[i]!r},"
                   f"{temperature[i]!r}\n")
    out = cli("sun", "--csv", "-", input_text=rows.getvalue()).stdout
    table = list(csv.DictReader(io.StringIO(out)))
    assert len(table) == n
    cli_elevation = np.array([float(r["elevation_deg"]) for r in table])
    cli_azimuth = np.array([float(r["azimuth_deg"]) for r in table])

    elevation, azimuth = relume.sun_positions(unix_ms / 1000.0, lat, lon, height, delta_t_s=delta_t,
                                              pressure_hpa=pressure, temperature_c=temperature)
    assert elevation.dtype == np.float64 and elevation.shape == (n,)
    d_elevation = np.abs(elevation - cli_elevation)
    d_azimuth = angle_difference_deg(azimuth, cli_azimuth)
    worst = int(np.argmax(np.maximum(d_elevation, d_azimuth)))
    print(f"max deviation from relume sun: elevation {d_elevation.max():.2e} deg, azimuth {d_azimuth.max():.2e} deg")
    assert d_elevation.max() <= TOLERANCE_DEG, table[worst]
    assert d_azimuth.max() <= TOLERANCE_DEG, table[worst]
    assert np.all((azimuth >= 0.0) & (azimuth < 360.0))


def test_the_spa_papers_example():
    # Reda & Andreas (2004), table A5.1: 2003-10-17 12:30:30 -07:00, Golden, Colorado.
    unix = datetime.datetime(2003, 10, 17, 19, 30, 30, tzinfo=datetime.timezone.utc).timestamp()
    elevation, azimuth = relume.sun_positions(unix, 39.742476, -105.1786, 1830.14, delta_t_s=67.0,
                                              pressure_hpa=820.0, temperature_c=11.0, dut1_s=0.0)
    assert isinstance(elevation, np.float64)  # scalars in, scalars out
    assert 90.0 - elevation == pytest.approx(50.11162, abs=2e-5)
    assert azimuth == pytest.approx(194.34024, abs=2e-5)


def test_the_three_paths_agree():
    # In order at one site: the time-series path along the given order.
    t = 1750000000.0 + np.arange(0.0, 2 * 86400.0, 7.3)
    elevation, azimuth = relume.sun_positions(t, 64.1, -21.9)
    order = np.random.default_rng(1).permutation(t.size)
    # Shuffled at one site: visited in time order (sorted inside), the same track path.
    e2, a2 = relume.sun_positions(t[order], 64.1, -21.9)
    assert np.max(np.abs(elevation[order] - e2)) < 1e-6
    assert np.max(angle_difference_deg(azimuth[order], a2)) < 1e-6
    # Random instants over two centuries: sorted along a track (one site given as a number)
    # against one full SPA per instant (the site given as an array, elements not reordered).
    far = np.random.default_rng(2).uniform(-2.2e9, 4.1e9, 20000)
    e3, a3 = relume.sun_positions(far, 64.1, -21.9)
    e4, a4 = relume.sun_positions(far, np.full(far.size, 64.1), -21.9)
    assert np.max(np.abs(e3 - e4)) < 1e-6
    assert np.max(angle_difference_deg(a3, a4)) < 1e-6


def test_arrays_broadcast_like_numpy():
    t = 1718971200.0 + np.arange(5.0)[:, None] * 3600.0  # (5, 1)
    lat = np.array([-60.0, 0.0, 37.97])  # (3,)
    elevation, azimuth = relume.sun_positions(t, lat, 23.7)
    assert elevation.shape == (5, 3) and azimuth.shape == (5, 3)
    for i in range(5):
        for j in range(3):
            e, a = relume.sun_positions(float(t[i, 0]), float(lat[j]), 23.7)
            assert elevation[i, j] == e and azimuth[i, j] == a
    # A non-contiguous view reads the right elements.
    strided = np.linspace(1.7e9, 1.8e9, 20)[::3]
    assert np.array_equal(relume.sun_positions(strided, 10.0, 20.0)[0],
                          relume.sun_positions(strided.copy(), 10.0, 20.0)[0])


def test_pressure_zero_means_no_refraction():
    t = 1718960000.0 + np.arange(0.0, 86400.0, 600.0)
    geometric, _ = relume.sun_positions(t, 48.0, 11.0, pressure_hpa=0.0)
    refracted, _ = relume.sun_positions(t, 48.0, 11.0)
    near_horizon = (geometric > 0.0) & (geometric < 2.0)  # below about -0.83 deg SPA applies none
    assert near_horizon.any()
    assert np.all(refracted[near_horizon] - geometric[near_horizon] > 0.1)  # ~0.3-0.6 deg near the horizon
    high = geometric > 30.0
    assert np.all(np.abs(refracted[high] - geometric[high]) < 0.03)


def test_invalid_input_raises_with_relumes_message():
    with pytest.raises(relume.InvalidArgumentError, match=r"latitude 91\.000000 deg is outside \[-90, 90\]") as error:
        relume.sun_positions([0.0, 1.0], [10.0, 91.0], 0.0)
    assert isinstance(error.value, ValueError) and isinstance(error.value, relume.Error)
    with pytest.raises(relume.InvalidArgumentError, match="do not broadcast"):
        relume.sun_positions(np.zeros(3), np.zeros(4), 0.0)
    with pytest.raises(relume.InvalidArgumentError, match=r"unix_seconds\[1\] = nan"):
        relume.sun_positions([0.0, np.nan], 0.0, 0.0)
    with pytest.raises(relume.InvalidArgumentError, match="pressure"):
        relume.sun_positions(0.0, 0.0, 0.0, pressure_hpa=-5.0)
