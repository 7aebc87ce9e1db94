"""Celestial targets: speed of observe() and rise/set search, accuracy against PyEphem.

    python benchmarks/bench_celestial.py

Prints figures only (no asserts). The baseline for observe() is the exact per-sample skyfield
call measured in the same run; the dense path evaluates 30 s nodes and interpolates.
"""

from __future__ import annotations

import math
import time
from datetime import datetime, timezone

import numpy as np

from tracker.celestial import resolve
from tracker.passes import find_passes
from tracker.skytrack import angular_separation_deg
from tracker.station import Station

UTC = timezone.utc
T0 = datetime(2026, 8, 22, 12, tzinfo=UTC)
STATION = Station("Dwingeloo", 52.81, 6.40, 20.0)


def _best_of(fn, repeat: int = 3) -> float:
    best = math.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _best_of_wall_cpu(fn, repeat: int = 3) -> tuple[float, float]:
    """Best wall time and best CPU time (process, all threads) of ``repeat`` calls."""
    wall = cpu = math.inf
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t)
        cpu = min(cpu, time.process_time() - c)
    return wall, cpu


def bench_observe() -> None:
    moon = resolve("moon")
    moon.observe(STATION, np.array([T0.timestamp()]))  # open the kernel once
    for step_s in (60.0, 1.0):
        t_s = T0.timestamp() + np.arange(0.0, 12 * 3600.0, step_s)
        fast = _best_of(lambda t_s=t_s: moon.observe(STATION, t_s))
        exact = _best_of(lambda t_s=t_s: moon._observe_exact(STATION, t_s), repeat=1)
        a = moon.observe(STATION, t_s)
        b = moon._observe_exact(STATION, t_s)
        err = angular_separation_deg(a.az_deg, a.el_deg, b.az_deg, b.el_deg).max()
        print(f"Moon observe 12 h at {step_s:g} s ({t_s.size} points): {fast * 1e3:7.1f} ms "
              f"(exact per-sample {exact * 1e3:7.1f} ms, ratio {exact / fast:5.1f}x; "
              f"max difference {err:.1e} deg)")


def bench_rise_set() -> None:
    end = T0.timestamp() + 7 * 86400
    for name in ("moon", "sun", "cas a"):
        target = resolve(name)
        wall, cpu = _best_of_wall_cpu(lambda target=target: find_passes(target, STATION, T0,
                                                                         end))
        print(f"{name:6s} 7-day rise/transit/set: find_passes {wall * 1e3:6.1f} ms wall, "
              f"{cpu * 1e3:6.1f} ms CPU")


def bench_accuracy() -> None:
    import ephem

    t_s = T0.timestamp() + np.arange(0.0, 3 * 86400.0, 1800.0)
    o = ephem.Observer()
    o.lat, o.lon = math.radians(STATION.lat_deg), math.radians(STATION.lon_deg)
    o.elevation, o.pressure = STATION.alt_m, 0.0
    for name in ("sun", "moon", "mars", "jupiter"):
        track = resolve(name).observe(STATION, t_s)
        body = getattr(ephem, name.capitalize())()
        az, el = [], []
        for t in t_s:
            o.date = ephem.Date(datetime.fromtimestamp(t, UTC).replace(tzinfo=None))
            body.compute(o)
            az.append(math.degrees(body.az))
            el.append(math.degrees(body.alt))
        sep = angular_separation_deg(track.az_deg, track.el_deg, np.array(az), np.array(el))
        print(f"{name:8s} vs PyEphem over 3 days ({t_s.size} samples): max {sep.max():.4f} "
              f"deg, mean {sep.mean():.4f} deg")
    moon = resolve("moon")
    o.horizon = 0.0
    diffs = []
    for p in find_passes(moon, STATION, T0, T0.timestamp() + 7 * 86400):
        if not (p.aos_known and p.los_known):
            continue
        for ours, fn in ((p.aos.timestamp(), o.next_rising),
                         (p.los.timestamp(), o.next_setting)):
            o.date = ephem.Date(datetime.fromtimestamp(ours - 3600, UTC).replace(tzinfo=None))
            theirs = fn(ephem.Moon(), use_center=True).datetime().replace(tzinfo=UTC)
            diffs.append(abs(ours - theirs.timestamp()))
    print(f"Moon rise/set vs PyEphem next_rising/next_setting (centre, no refraction), "
          f"{len(diffs)} events: max {max(diffs):.2f} s")


if __name__ == "__main__":
    bench_observe()
    bench_rise_set()
    bench_accuracy()
