"""Pointing benchmark: the planner vs a Gpredict-style rule over the pass suite.

Run: ``python benchmarks/pointing.py [--quick] [--rotator G-5500] [--mains-hz 50]``

For every pass of the suite (bundled amateur + weather groups, 7 days, three stations, plus
forced overhead passes) each policy plans the pass for the same rotator; both go through the
same command quantisation, lead and motor model, so only the path policy differs. Prints,
per policy: mode counts, max and p99 pointing error over all visible seconds, lost seconds
(error > 5 deg while the target is up), passes with any loss, travel, and planning time per
pass. Times are a ratio against the baseline measured in the same run.

Then (``--streaming also``, the default) the live loop's streaming policy flies the same
passes, judged at equal accuracy against a Gpredict-style and a SatNOGS-style loop
(benchmarks/streaming.py): lost-track seconds, error, motor starts, the lower bound on starts;
``--streaming only`` prints just that part.

Add a policy by adding an entry to POLICIES: ``name -> fn(track, spec, station) -> MountPlan``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from passsuite import SuitePass, pass_suite

from tracker.mount import preset
from tracker.planner import MountPlan, gpredict_plan, plan_pass


def planner_policy(track, spec, station) -> MountPlan:
    return plan_pass(track, spec, station)


def gpredict_policy(track, spec, station) -> MountPlan:
    return gpredict_plan(track, spec, station)


POLICIES: dict[str, Callable] = {"planner": planner_policy, "gpredict-rule": gpredict_policy}


def run_policy(fn: Callable, suite: list[SuitePass], spec) -> dict:
    modes: Counter = Counter()
    errors = []
    lost_s = 0.0
    lost_passes = 0
    travel = 0.0
    worst = (0.0, "")
    t0 = time.perf_counter()
    for sp in suite:
        plan = fn(sp.track, spec, sp.station)
        modes[plan.mode] += 1
        errors.append(plan.error_deg[plan.visible])
        lost_s += plan.lost_track_s
        lost_passes += plan.lost_track_s > 0
        travel += plan.travel_deg
        if plan.max_error_deg > worst[0]:
            worst = (plan.max_error_deg, f"{sp.meta['target']} @ {sp.meta['station']}")
    elapsed = time.perf_counter() - t0
    all_err = np.concatenate(errors)
    return {"modes": modes, "max": float(all_err.max()), "p99": float(np.percentile(all_err, 99)),
            "mean": float(all_err.mean()), "lost_s": lost_s, "lost_passes": lost_passes,
            "travel": travel, "ms_per_pass": 1000 * elapsed / len(suite), "worst": worst,
            "visible_s": float(len(all_err))}


def _mode_count(mode: str) -> Callable[[dict], str]:
    return lambda r: f"{r['modes'].get(mode, 0)}"


def print_table(results: dict[str, dict], n_passes: int) -> None:
    names = list(results)
    w = max(16, *(len(n) + 2 for n in names))
    rows = [
        ("passes", lambda r: f"{n_passes}"),
        *[(f"mode {m}", _mode_count(m))
          for m in ("normal", "overlap", "flip", "keyhole", "unwind", "ahead")],
        ("max error deg", lambda r: f"{r['max']:.2f}"),
        ("p99 error deg", lambda r: f"{r['p99']:.2f}"),
        ("mean error deg", lambda r: f"{r['mean']:.3f}"),
        ("lost s (>5 deg)", lambda r: f"{r['lost_s']:.0f}"),
        ("lost % of up", lambda r: f"{100 * r['lost_s'] / r['visible_s']:.3f}"),
        ("passes with loss", lambda r: f"{r['lost_passes']}"),
        ("travel deg/pass", lambda r: f"{r['travel'] / n_passes:.0f}"),
        ("ms per pass", lambda r: f"{r['ms_per_pass']:.2f}"),
    ]
    print(f"{'':<20}" + "".join(f"{n:>{w}}" for n in names))
    for label, fmt in rows:
        print(f"{label:<20}" + "".join(f"{fmt(results[n]):>{w}}" for n in names))
    base = names[-1]
    for n in names[:-1]:
        print(f"planning time ratio {n}/{base}: "
              f"{results[n]['ms_per_pass'] / results[base]['ms_per_pass']:.2f}")
    for n in names:
        print(f"worst pass for {n}: {results[n]['worst'][0]:.1f} deg ({results[n]['worst'][1]})")


def motor_model_speed(suite: list[SuitePass], spec, repeats: int = 3) -> None:
    """drive_axis in closed form (AxisMotor for overlaps) vs stepping AxisMotor per command."""
    from tracker.mount import AxisMotor, drive_axis

    plans = [plan_pass(sp.track, spec, sp.station) for sp in suite[:40]]
    streams = [(*plan.commands()[:2], plan.t_s) for plan in plans]

    def axis(a0: float) -> AxisMotor:
        return AxisMotor(0, spec.az_span_deg, spec.az_rate_deg_s, spec.start_delay_s, 1.0, a0,
                         0.0)

    t0 = time.perf_counter()
    for _ in range(repeats):
        fast = [drive_axis(axis(a[0]), t, a, te)[0] for t, a, te in streams]
    t_fast = time.perf_counter() - t0
    t0 = time.perf_counter()
    slow = [drive_axis(axis(a[0]), t, a, te, closed_form=False)[0] for t, a, te in streams
            for _ in range(repeats)][::repeats]
    t_slow = time.perf_counter() - t0
    diff = max(float(np.max(np.abs(f - s))) for f, s in zip(fast, slow, strict=True))
    print(f"\nmotor model on {len(streams)} az command streams: closed form "
          f"{1000 * t_fast / (repeats * len(streams)):.3f} ms/pass, stepping "
          f"{1000 * t_slow / (repeats * len(streams)):.3f} ms/pass (x{t_slow / t_fast:.0f}); "
          f"max difference {diff:.2e} deg")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 day, 30 satellites per group")
    ap.add_argument("--rotator", default="G-5500")
    ap.add_argument("--mains-hz", type=int, default=50, choices=(50, 60))
    ap.add_argument("--days", type=float, default=None)
    ap.add_argument("--streaming", choices=("also", "only", "off"), default="also",
                    help="the live loop's streaming policy vs a Gpredict-style loop on the "
                         "same suite (benchmarks/streaming.py): after the planner tables "
                         "(also), alone (only), or not at all (off)")
    args = ap.parse_args(argv)
    spec = preset(args.rotator, args.mains_hz)
    days = args.days or (1.0 if args.quick else 7.0)
    t0 = time.perf_counter()
    suite = pass_suite(days=days, max_sats=30 if args.quick else None)
    real = sum(sp.meta["kind"] == "real" for sp in suite)
    print(f"rotator {spec.name}: az {360 / spec.az_rate_deg_s:.0f} s/360, el "
          f"{180 / spec.el_rate_deg_s:.0f} s/180, span {spec.az_span_deg:g}, el max "
          f"{spec.el_max_deg:g}")
    print(f"suite: {real} real passes (amateur + weather, {days:g} d, 3 stations) + "
          f"{len(suite) - real} forced overhead; built in {time.perf_counter() - t0:.1f} s")
    if args.streaming != "only":
        results = {name: run_policy(fn, suite, spec) for name, fn in POLICIES.items()}
        print_table(results, len(suite))
        overhead = [sp for sp in suite if sp.meta["kind"] == "overhead"]
        print("\nforced overhead passes only:")
        print_table({name: run_policy(fn, overhead, spec) for name, fn in POLICIES.items()},
                    len(overhead))
        motor_model_speed(suite, spec)
    if args.streaming != "off":
        streaming_policy(suite, spec)
    return 0


def streaming_policy(suite: list[SuitePass], spec, deadbands=(3.0, 5.0)) -> None:
    """The live loop (tracker.stream, deadband + aim point, 0.5 s read-back) flying the
    same passes on the same simulated rotator, judged at equal accuracy against a
    Gpredict-style and a SatNOGS-style loop (benchmarks/streaming.py)."""
    from streaming import compare, print_results

    t0 = time.perf_counter()
    print(f"\nstreaming policy vs Gpredict-style and SatNOGS-style loops, same suite and "
          f"rotator ({len(suite)} passes):")
    res = compare(suite, spec, list(deadbands), joint=False)
    print_results(res, len(suite))
    print(f"streaming comparison took {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
