#!/usr/bin/env python3
"""Times relume.sun_positions from Python: 1 M positions, three ways (issue 22's goal is
>= 1 M positions/s). A benchmark, not a test: it prints, it asserts nothing.

    PYTHONPATH=build/release/python python3 python/bench_sun.py [--count N] [--threads T]
"""
import argparse
import time

import numpy as np

import relume


def best_rate(count, repeats, call):
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return count / best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=0, help="0 = every core")
    args = parser.parse_args()
    n = args.count
    rng = np.random.default_rng(0)
    series = 1718971200.0 + np.arange(n) * (86400.0 * 7 / n)  # one site, a week, in order
    random_times = rng.uniform(-2208988800.0, 4102444800.0, n)  # 1900..2100, in any order
    lat = rng.uniform(-89.0, 89.0, n)
    lon = rng.uniform(-180.0, 180.0, n)
    cases = [
        ("a time series at one site (the CLI's SunTrack path)",
         lambda: relume.sun_positions(series, 37.9715, 23.7257, threads=args.threads)),
        ("random times at one site (sorted inside, then the SunTrack path)",
         lambda: relume.sun_positions(random_times, 37.9715, 23.7257, threads=args.threads)),
        ("random times and sites (one full SPA per position)",
         lambda: relume.sun_positions(random_times, lat, lon, threads=args.threads)),
    ]
    print(f"relume.sun_positions, {n} positions, threads={args.threads or 'all'}, best of {args.repeats}")
    for name, call in cases:
        print(f"  {best_rate(n, args.repeats, call):>12,.0f} positions/s  {name}")


if __name__ == "__main__":
    main()
