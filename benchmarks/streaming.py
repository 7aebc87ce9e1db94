"""Streaming benchmark: the live loop's policy vs a Gpredict-style loop on a simulated G-5500.

Run: ``python benchmarks/streaming.py [--days 1] [--max-sats 30] [--deadband 3]
[--sample N]`` (the 7-day suite: ``--days 7 --max-sats 0``; ``--sample`` flies N passes spread
evenly over it)

Both policies fly every pass of the pass suite (benchmarks/passsuite.py) against the same
simulated rotator (THE motor model, tracker.mount, G-5500 at 50 Hz rates), starting parked:

* ``stream``: :class:`tracker.stream.TrackCore` exactly as ``tracker track`` runs it: the
  planner's path (overlap / flip / keyhole chosen per pass), mask-safe pre-position, deadband
  with the aim point chosen by :func:`tracker.aim.choose_aim`, read-back (integer degrees)
  every 0.5 s cycle.
* ``gpredict``: gtk-rot-ctrl.c: 1 s cycle, 5 deg threshold per axis between the current target
  and the read-back, lead = the furthest future point within the threshold (bisection), flip
  only when el max is 180 (``maxel >= 180``), no overlap, targets clamped.

Per policy: max / p99 great-circle pointing error over all visible time (sampled every
0.25 s), lost-track seconds (error > 5 deg while up; also on the passes the planner calls
followable), passes with max error <= 3 deg, motor starts and commands sent, and the
simulation cost per pass (ratio against the baseline in the same run). Each stream pass with
lost seconds is listed with the planner's predicted loss and the clairvoyant per-axis bound
(:func:`start_bound` at the lost-track limit): whether the rotator could follow it at all.
The decision cost per cycle alone: benchmarks/decision_cost.py.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from passsuite import pass_suite, sample_suite

from tracker.aim import gpredict_aim
from tracker.geometry import MountPath, pointing_error_deg
from tracker.mount import AxisMotor, MotorModel, drive_axis, preset
from tracker.planner import gpredict_plan, plan_pass
from tracker.stream import StreamSettings, TrackCore, pass_window

LOST_DEG = 5.0
SAMPLE_S = 0.25


def _readback(truth: MotorModel, t: float) -> tuple[float, float]:
    az, el = truth.position(t)
    return float(round(az)), float(round(el))


class CycleMeter:
    """CPU time of the live loop's per-cycle work (what :func:`tracker.stream.run_pass` asks
    of :class:`TrackCore` each cycle: observe, decide, commanded, status), over cycles."""

    def __init__(self) -> None:
        self.cpu_ns = 0
        self.cycles = 0

    @property
    def us_per_cycle(self) -> float:
        return self.cpu_ns / 1000.0 / max(self.cycles, 1)


def fly_stream(track, spec, station, deadband_deg: float, cycle_s: float = 0.5,
               meter: CycleMeter | None = None):
    """The live loop's decisions against a simulated rotator; returns (cmd_t, az, el), plan.

    With ``meter`` the core's per-cycle calls (and the status the live loop shows each cycle)
    are timed in CPU time; the commands are the same either way."""
    plan = plan_pass(track, spec, station, current=(spec.park_az_deg, spec.park_el_deg))
    core = TrackCore(plan, track, spec, station,
                     StreamSettings(deadband_deg=deadband_deg, cycle_s=cycle_s))
    t = min(core.preposition_t_s, float(track.t_s[0])) - cycle_s
    truth = MotorModel(spec, spec.park_az_deg, spec.park_el_deg, t)
    cmds = []
    cpu_ns = time.thread_time_ns
    while t <= core.los_s:
        wire = _readback(truth, t)
        c0 = cpu_ns() if meter is not None else 0
        core.observe(t, *wire)
        cmd = core.decide(t)
        if cmd is not None:
            core.commanded(t, cmd)
        if meter is not None:
            core.status(t)
            meter.cpu_ns += cpu_ns() - c0
            meter.cycles += 1
        if cmd is not None:
            truth.command(cmd.az_m_deg, cmd.el_deg, t)
            cmds.append((t, cmd.az_m_deg, cmd.el_deg))
        t += cycle_s
    return cmds, plan, t


def fly_gpredict(track, spec, station, threshold_deg: float = 5.0, cycle_s: float = 1.0,
                 t_start: float | None = None):
    """Gpredict's rot_ctrl_timeout_cb loop (gtk-rot-ctrl.c) on the Gpredict path rule."""
    plan = gpredict_plan(track, spec, station, current=(spec.park_az_deg, spec.park_el_deg))
    path = MountPath.exact_from_plan(plan, track, spec)
    aos_s, los_s = pass_window(track, station)
    t = float(track.t_s[0]) if t_start is None else t_start
    truth = MotorModel(spec, spec.park_az_deg, spec.park_el_deg, t)
    res = spec.resolution_deg

    def quantise(a, e):
        return (min(max(round(a / res) * res, 0.0), spec.az_span_deg),
                min(max(round(e / res) * res, spec.el_min_deg), spec.el_max_deg))

    cmds = []
    while t <= los_s:
        set_az, set_el = path.mount_at(max(t, path.start_s))
        rot_az, rot_el = _readback(truth, t)
        if abs(set_az - rot_az) > threshold_deg or abs(set_el - rot_el) > threshold_deg:
            if t >= aos_s:
                az, el = gpredict_aim(path, t, threshold_deg, cycle_s, quantise)
            else:   # before AOS Gpredict sends the AOS azimuth at 0 deg (here: the AOS point)
                az, el = quantise(set_az, set_el)
            truth.command(az, el, t)
            cmds.append((t, az, el))
        t += cycle_s
    return cmds, plan


def axis_start_bound(t_s: np.ndarray, path_deg: np.ndarray, weight: np.ndarray, rate_deg_s: float,
                     start_delay_s: float, bound_deg: float, cycle_s: float = 0.5
                     ) -> int | None:
    """Fewest motor starts one axis needs to keep ``weight * |antenna - path|`` within
    ``bound_deg`` (None: it cannot), found greedily with full knowledge of the future:
    command as late as the 0.5 s cycle allows, to the integer target held longest.

    An optimistic bound for the live loop: it knows the future, the other axis is assumed
    perfect (the great-circle error is at least each axis's share of it: elevation error,
    and azimuth error times cos(el)), and the antenna starts at rest on the AOS point.
    """
    dt = float(t_s[1] - t_s[0])
    n, i, starts = len(t_s), 0, 0
    p = float(np.round(path_deg[0]))
    step = max(1, round(cycle_s / dt))
    while True:
        bad = np.flatnonzero(weight[i:] * np.abs(p - path_deg[i:]) > bound_deg)
        if len(bad) == 0:
            return starts
        j = i + int(bad[0])
        qs = np.arange(np.floor(path_deg[j]) - 12.0, np.ceil(path_deg[j]) + 13.0)
        best = None
        for k in range(j, i - 1, -step):          # latest command time first
            tk = t_s[k] + start_delay_s
            run = np.clip((t_s[None, i:] - tk) * rate_deg_s, 0.0, np.abs(qs - p)[:, None])
            pos = p + np.sign(qs - p)[:, None] * run
            off = weight[None, i:] * np.abs(pos - path_deg[None, i:]) > bound_deg
            leave = np.where(off.any(axis=1), np.argmax(off, axis=1), n - i) + i
            arrive = tk + np.abs(qs - p) / rate_deg_s
            good = (leave >= n) | (t_s[np.minimum(leave, n - 1)] > arrive)
            if good.any():
                q = int(np.argmax(np.where(good, leave, -1)))
                best = (float(qs[q]), int(leave[q]), float(arrive[q]))
                break
        if best is None:
            return None
        starts += 1
        p, leave, arrive = best
        if leave >= n:
            return starts
        i = min(int(np.ceil((arrive - t_s[0]) / dt)), n - 1)


def start_bound(track, spec, station, bound_deg: float) -> int | None:
    """:func:`axis_start_bound` summed over both axes on the planner's path, AOS..LOS."""
    plan = plan_pass(track, spec, station, current=(spec.park_az_deg, spec.park_el_deg))
    path = MountPath.exact_from_plan(plan, None, spec)
    aos_s, los_s = pass_window(track, station)
    ts = np.arange(aos_s, los_s + 1e-9, SAMPLE_S)
    if len(ts) < 2:
        return 0
    az, el = path.mount_at(ts)
    n_az = axis_start_bound(ts, az, np.abs(np.cos(np.radians(el))), spec.az_rate_deg_s,
                            spec.start_delay_s, bound_deg)
    n_el = axis_start_bound(ts, el, np.ones_like(el), spec.el_rate_deg_s, spec.start_delay_s,
                            bound_deg)
    return None if n_az is None or n_el is None else n_az + n_el


def measure(track, spec, station, cmds, t_start: float) -> dict:
    """Replay the commands through the motor model; error against the real target."""
    aos_s, los_s = pass_window(track, station)
    ts = np.arange(aos_s, los_s + 1e-9, SAMPLE_S)
    c = np.array(cmds, dtype=float) if cmds else np.zeros((0, 3))
    az_axis = AxisMotor(0.0, spec.az_span_deg, spec.az_rate_deg_s, spec.start_delay_s,
                        spec.resolution_deg, spec.park_az_deg, t_start)
    el_axis = AxisMotor(spec.el_min_deg, spec.el_max_deg, spec.el_rate_deg_s,
                        spec.start_delay_s, spec.resolution_deg, spec.park_el_deg, t_start)
    if len(c):
        az, starts_az = drive_axis(az_axis, c[:, 0], c[:, 1], ts)
        el, starts_el = drive_axis(el_axis, c[:, 0], c[:, 2], ts)
    else:
        az, el, starts_az, starts_el = np.full(ts.shape, spec.park_az_deg), np.full(
            ts.shape, spec.park_el_deg), 0, 0
    taz, tel = track.direction_at(ts)
    err = pointing_error_deg(spec, az, el, (taz, tel))
    return {"err": err, "lost_s": float(np.sum(err > LOST_DEG) * SAMPLE_S),
            "starts": int(starts_az + starts_el), "commands": len(cmds)}


def summarise(rows: list[dict], followable: np.ndarray, bound: np.ndarray) -> dict:
    """``bound``: per pass, the planner's predicted max error plus the deadband."""
    err = np.concatenate([r["err"] for r in rows])
    per_max = np.array([r["err"].max() for r in rows])
    lost = np.array([r["lost_s"] for r in rows])
    return {"max": float(err.max()), "p99": float(np.percentile(err, 99)),
            "mean": float(err.mean()), "lost_s": float(lost.sum()),
            "lost_followable_s": float(lost[followable].sum()),
            "passes_lost": int(np.sum(lost > 0)),
            "le3": float(np.mean(per_max <= 3.0)),
            "in_bound": float(np.mean(per_max <= bound + 1e-9)),
            "starts": sum(r["starts"] for r in rows),
            "commands": sum(r["commands"] for r in rows)}


def compare(suite, spec, deadbands: list[float]) -> tuple[dict, list[str], np.ndarray]:
    """Fly every pass of ``suite`` with the stream policy at each deadband and with the
    Gpredict-style loop; returns (summary per policy, stream policy names, followable).
    ``res["lossy"]`` lists the stream policy's passes with lost seconds: (policy, target,
    station, max el, lost s, the planner's predicted lost s, whether :func:`start_bound`
    finds each axis able to keep within the lost-track limit knowing the future)."""
    names = [f"stream D={d:g}" for d in deadbands]
    rows: dict[str, list] = {n: [] for n in [*names, "gpredict-style"]}
    cost = dict.fromkeys(rows, 0.0)
    followable = []
    plan_max = []
    lossy: list[tuple] = []
    for sp in suite:
        tr, st = sp.track, sp.station
        t_start = None
        for name, d in zip(names, deadbands, strict=True):
            t1 = time.perf_counter()
            cmds, plan, _t = fly_stream(tr, spec, st, d)
            t_start = min(plan.preposition_t_s, float(tr.t_s[0])) - 0.5
            rows[name].append(measure(tr, spec, st, cmds, t_start))
            cost[name] += time.perf_counter() - t1
        plan_max.append(plan.max_error_deg)
        t2 = time.perf_counter()
        gcmds, _gplan = fly_gpredict(tr, spec, st, t_start=t_start)
        rows["gpredict-style"].append(measure(tr, spec, st, gcmds, t_start))
        cost["gpredict-style"] += time.perf_counter() - t2
        followable.append(plan.lost_track_s == 0)
        meta = sp.meta
        for name in names:
            lost_s = rows[name][-1]["lost_s"]
            if lost_s > 0:
                # Knowing the future, can each axis alone keep within the lost-track limit?
                # (None: no: the rotator cannot physically follow this pass.)
                starts = start_bound(tr, spec, st, LOST_DEG)
                lossy.append((name, meta["target"], meta["station"], meta["max_el_deg"],
                              lost_s, float(plan.lost_track_s), starts is not None))
    followable = np.array(followable)
    plan_max = np.array(plan_max)
    bounds = dict(zip(names, deadbands, strict=True))
    res = {k: summarise(v, followable, plan_max + bounds.get(k, 5.0)) for k, v in rows.items()}
    for k in res:
        res[k]["cost"] = cost[k]
    res["lossy"] = lossy
    return res, names, followable


def print_results(res: dict, names: list[str], followable: np.ndarray) -> None:
    """The side-by-side table and, per stream deadband, the three targets: no lost seconds on
    followable passes, max error <= 3 deg on >= 99 % of passes, motor starts vs Gpredict's."""
    n = len(followable)
    lossy = res.pop("lossy", [])
    labels = [
        ("passes", lambda r: f"{n}"),
        ("max error deg", lambda r: f"{r['max']:.2f}"),
        ("p99 error deg", lambda r: f"{r['p99']:.2f}"),
        ("mean error deg", lambda r: f"{r['mean']:.2f}"),
        ("lost s (>5 deg, all)", lambda r: f"{r['lost_s']:.1f}"),
        ("lost s, followable", lambda r: f"{r['lost_followable_s']:.1f}"),
        ("passes with loss", lambda r: f"{r['passes_lost']}"),
        ("passes max<=3 deg %", lambda r: f"{100 * r['le3']:.1f}"),
        ("max<=plan+deadband %", lambda r: f"{100 * r['in_bound']:.1f}"),
        ("motor starts", lambda r: f"{r['starts']}"),
        ("starts per pass", lambda r: f"{r['starts'] / n:.1f}"),
        ("commands sent", lambda r: f"{r['commands']}"),
        ("sim ms per pass", lambda r: f"{1000 * r['cost'] / n:.1f}"),
    ]
    print(f"\n{'policy':<24}" + "".join(f"{k:>17}" for k in res))
    for label, fmt in labels:
        print(f"{label:<24}" + "".join(f"{fmt(r):>17}" for r in res.values()))
    print(f"followable passes (planner predicts no loss): {int(followable.sum())} of {n}")
    for name, target, station, max_el, lost_s, plan_lost_s, feasible in lossy:
        why = ("the planner predicts loss too" if plan_lost_s > 0 else
               "FOLLOWABLE by the planner's prediction")
        bound = ("feasible: each axis alone can keep the planner's path within 5 deg "
                 "knowing the future" if feasible else
                 "INFEASIBLE: an axis cannot keep the planner's path within 5 deg even "
                 "knowing the future")
        print(f"  lossy {name}: {target} from {station}, max el {max_el:.1f}: lost "
              f"{lost_s:.2f} s; planner predicts {plan_lost_s:.1f} s ({why}); clairvoyant "
              f"bound: {bound}")
    g = res["gpredict-style"]
    for name in names:
        s = res[name]
        print(f"{name}: no lost s on followable passes: "
              f"{'yes' if s['lost_followable_s'] == 0 else 'NO'}; max <= 3 deg on >= 99 % of "
              f"passes: {'yes' if s['le3'] >= 0.99 else 'NO'} ({100 * s['le3']:.1f} %); "
              f"motor starts vs gpredict-style: {s['starts'] / g['starts']:.2f}x; "
              f"sim cost vs gpredict-style: {s['cost'] / max(g['cost'], 1e-9):.0f}x")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=float, default=1.0)
    ap.add_argument("--max-sats", type=int, default=30,
                    help="satellites per group (0 = all)")
    ap.add_argument("--deadband", type=float, nargs="+", default=[3.0, 5.0],
                    help="deadbands (great-circle deg) to run the stream policy at")
    ap.add_argument("--rotator", default="G-5500")
    ap.add_argument("--mains-hz", type=int, default=50, choices=(50, 60))
    ap.add_argument("--overhead", type=int, default=24)
    ap.add_argument("--sample", type=int, default=0,
                    help="fly only this many passes spread evenly over the suite (0 = all)")
    ap.add_argument("--bound-deg", type=float, default=3.0,
                    help="also print the fewest motor starts any policy needs for this max "
                         "error (0 = skip)")
    args = ap.parse_args(argv)
    spec = preset(args.rotator, args.mains_hz)
    t0 = time.perf_counter()
    suite = pass_suite(days=args.days, max_sats=args.max_sats or None,
                       n_overhead=args.overhead)
    if args.sample:
        print(f"sample: {min(args.sample, len(suite))} of {len(suite)} passes, evenly spread")
        suite = sample_suite(suite, args.sample)
    print(f"rotator {spec.name}: az {spec.az_rate_deg_s:.2f} deg/s, el "
          f"{spec.el_rate_deg_s:.2f} deg/s, start delay {spec.start_delay_s:g} s, span "
          f"{spec.az_span_deg:g}, el max {spec.el_max_deg:g}")
    real = sum(sp.meta["kind"] == "real" for sp in suite)
    print(f"suite: {real} real passes ({args.days:g} d, {args.max_sats or 'all'} sats/group, "
          f"3 stations) + {len(suite) - real} forced overhead; built in "
          f"{time.perf_counter() - t0:.1f} s")
    res, names, followable = compare(suite, spec, args.deadband)
    print_results(res, names, followable)
    if args.bound_deg > 0:
        b = [start_bound(sp.track, spec, sp.station, args.bound_deg) for sp in suite]
        ok = [x for x in b if x is not None]
        g = res["gpredict-style"]["starts"] / len(suite)
        print(f"lower bound for max error <= {args.bound_deg:g} deg (each axis alone, knowing "
              f"the future, 0.5 s cycle, integer targets, no pre-position): "
              f"{np.mean(ok):.1f} tracking starts per pass ({len(ok)} of {len(b)} passes "
              f"feasible); gpredict-style {g:.1f} starts per pass incl. pre-position")
    return 0


if __name__ == "__main__":
    sys.exit(main())
