"""Benchmark pass prediction: wall time of the CLI and accuracy against a fine reference.

    python benchmarks/passes.py [--runs 5] [--sats 12] [--days 2]

1. Wall time of ``tracker passes ISS`` as a whole process (median of --runs), next to two
   baselines measured in the same run: the interpreter importing skyfield + numpy, and
   ``tracker --help``. The element cache and config dir are empty temp dirs, so the bundled
   snapshot and the default station are used, as on a fresh machine.
2. Accuracy: for ISS, NOAA 20, AO-10 (deep space) and the first --sats amateur satellites,
   over --days from 2026-08-23 at 52N 4.4E, every AOS/LOS is compared with the crossing
   found by 0.1 s brute-force sampling (skyfield directly, IAU 2000A nutation) and every TCA
   with the 0.1 s maximum; skyfield's own ``find_events`` (what we refine) is measured the
   same way as the baseline. A 10 s scan of the whole window counts passes to catch misses.
   The same is repeated with a horizon mask (passes cut by a 25 degree wall).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REF_MIDNIGHT_S = 1787443200.0  # 2026-08-23T00:00:00Z


def wall_times(argv: list[str], runs: int, env: dict) -> list[float]:
    out = []
    for _ in range(runs):
        t = time.perf_counter()
        r = subprocess.run(argv, capture_output=True, text=True, env=env)
        out.append(time.perf_counter() - t)
        if r.returncode != 0:
            sys.exit(f"{' '.join(argv)} failed: {r.stderr}")
    return out


def bench_cli(runs: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, XDG_CACHE_HOME=f"{tmp}/cache", XDG_CONFIG_HOME=f"{tmp}/config")
        env.pop("TRACKER_CONFIG", None)
        py = sys.executable
        base_import = statistics.median(wall_times(
            [py, "-c", "import numpy, skyfield.api"], runs, env))
        base_help = statistics.median(wall_times([py, "-m", "tracker", "--help"], runs, env))
        times = wall_times([py, "-m", "tracker", "passes", "ISS"], runs, env)
        med = statistics.median(times)
        print(f"wall time `tracker passes ISS` (median of {runs}): {med:.3f} s "
              f"[min {min(times):.3f}, max {max(times):.3f}]")
        print(f"  baseline `python -c 'import numpy, skyfield.api'`: {base_import:.3f} s "
              f"-> ratio {med / base_import:.2f}")
        print(f"  baseline `tracker --help`: {base_help:.3f} s -> ratio {med / base_help:.2f}")


def reference(sat, station, t_s):
    from skyfield.api import load

    ts = load.timescale(builtin=True)
    # Seconds from a nearby midnight: skyfield's utc() takes the leap-second count at the
    # given date, so seconds counted from 1970 would be off by 27 s. (No leap second in 2026.)
    t = ts.utc(2026, 8, 23, 0, 0, np.asarray(t_s) - REF_MIDNIGHT_S)
    alt, az, _ = (sat - station.topos()).at(t).altaz()
    return alt.degrees - station.horizon_at(az.degrees), alt.degrees


def ref_crossing(sat, station, t_c: float, half_s: float = 30.0) -> float | None:
    t = np.arange(t_c - half_s, t_c + half_s, 0.1)
    g, _ = reference(sat, station, t)
    up = g > 0
    idx = np.flatnonzero(up[1:] != up[:-1])
    if len(idx) != 1:
        return None
    i = idx[0]
    return float(t[i] + 0.1 * g[i] / (g[i] - g[i + 1]))


def ref_tca(sat, station, a: float, b: float) -> float:
    t = np.linspace(a, b, 600)
    _, el = reference(sat, station, t)
    c = t[int(np.argmax(el))]
    d = t[1] - t[0]
    tf = np.arange(max(a, c - 2 * d), min(b, c + 2 * d), 0.1)
    _, elf = reference(sat, station, tf)
    return float(tf[int(np.argmax(elf))])


def coarse_count(sat, station, t0: float, t1: float) -> int:
    t = np.arange(t0, t1, 10.0)
    g, _ = reference(sat, station, t)
    up = g > 0
    return int(np.count_nonzero(up[1:] & ~up[:-1]))


# A benchmark's measuring loop: one piece, so each number it prints reads against the
# code that takes it.
def bench_accuracy(n_sats: int, days: float) -> None:  # noqa: C901
    from tle.catalog import Catalog
    from tracker.clock import utc
    from tracker.passes import find_passes
    from tracker.station import HorizonMask, Station
    from tracker.targets import SatelliteTarget
    from tracker.timescale import posix_from_time, time_from_posix

    catalog = Catalog.bundled_snapshot(on_warning=lambda m: None)
    names = ["ISS (ZARYA)", "NOAA 20 (JPSS-1)", "PHASE 3B (AO-10)"]
    names += [es.name for es in list(catalog.group("amateur"))[:n_sats]]
    targets = []
    for n in dict.fromkeys(names):
        try:
            targets.append(SatelliteTarget(catalog.find(n)))
        except Exception as e:  # a benchmark reports and moves on
            print(f"  skip {n}: {e}")
    station = Station("bench", 52.0, 4.4, 10.0)
    with tempfile.TemporaryDirectory() as tmp:
        mask_file = Path(tmp) / "mask.txt"
        mask_file.write_text("0 3\n180 3\n190 25\n300 25\n310 3\n")
        masked = replace(station, mask=HorizonMask.load(mask_file))
    t0, t1 = utc(2026, 8, 23).timestamp(), utc(2026, 8, 23).timestamp() + days * 86400
    for label, st in (("open horizon", station), ("horizon mask", masked)):
        d_ours: list[float] = []
        d_tca: list[float] = []
        d_sky: list[float] = []
        n_pass = missed = 0
        elapsed = 0.0
        for tg in targets:
            tick = time.perf_counter()
            passes = find_passes(tg, st, t0, t1)
            elapsed += time.perf_counter() - tick
            complete = [p for p in passes if p.aos_known and p.los_known
                        and t0 <= p.aos.timestamp() and p.los.timestamp() <= t1]
            n_ref = coarse_count(tg.satellite, st, t0, t1)
            inside = [p for p in passes if p.aos_known and t0 <= p.aos.timestamp() <= t1]
            missed += abs(n_ref - len(inside))
            for p in complete:
                n_pass += 1
                for when in (p.aos.timestamp(), p.los.timestamp()):
                    ref = ref_crossing(tg.satellite, st, when)
                    if ref is not None:
                        d_ours.append(abs(ref - when))
                d_tca.append(abs(ref_tca(tg.satellite, st, p.aos.timestamp(),
                                         p.los.timestamp()) - p.tca.timestamp()))
            if st.mask is None:  # skyfield's raw events, same reference
                times, events = tg.satellite.find_events(
                    st.topos(), time_from_posix(t0), time_from_posix(t1), altitude_degrees=0.0)
                for t_e, code in zip(np.atleast_1d(posix_from_time(times)), events,
                                     strict=True):
                    if code in (0, 2):
                        ref = ref_crossing(tg.satellite, st, float(t_e))
                        if ref is not None:
                            d_sky.append(abs(ref - float(t_e)))
        print(f"accuracy, {label}: {len(targets)} satellites, {n_pass} complete passes in "
              f"{days:g} days ({elapsed:.2f} s to find them)")
        print(f"  AOS/LOS max |dt| {max(d_ours):.3f} s, median {statistics.median(d_ours):.3f} s"
              f" ({len(d_ours)} events)")
        print(f"  TCA     max |dt| {max(d_tca):.3f} s, median {statistics.median(d_tca):.3f} s")
        print(f"  passes missed or extra vs a 10 s scan: {missed}")
        if d_sky:
            print(f"  baseline skyfield find_events AOS/LOS: max |dt| {max(d_sky):.3f} s, median "
                  f"{statistics.median(d_sky):.3f} s -> ours is "
                  f"{max(d_sky) / max(max(d_ours), 1e-9):.0f}x tighter (max)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sats", type=int, default=12)
    ap.add_argument("--days", type=float, default=2.0)
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    bench_cli(args.runs)
    bench_accuracy(args.sats, args.days)


if __name__ == "__main__":
    main()
