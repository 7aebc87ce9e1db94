"""Streaming benchmark: the live loop's pointing judged at equal accuracy, on a simulated G-5500.

Run: ``python benchmarks/streaming.py [--sample 100] [--deadband 2 3 4 5] [--days 1]
[--max-sats 30] [--no-peers] [--no-joint] [--bound-every N] [--workers N]
[--kernels best|numba|numpy]``
(the whole 1-day suite: ``--sample 0``; the 7-day suite: ``--days 7 --max-sats 0 --sample N``;
``--sample`` flies N passes spread evenly; ``--workers`` shares the passes among N processes,
the same results; ``--kernels``: the whole-pass programme compiled by numba where it runs,
the same schedules; ``--bound-every N``: the bound on every N-th pass only, for the big suites)

Every policy flies the passes of the pass suite (benchmarks/passsuite.py) against the same
simulated rotator (THE motor model, tracker.mount, G-5500 at 50 Hz rates), starting parked:

* ``stream``: :class:`tracker.stream.TrackCore` exactly as ``tracker track`` runs it: the
  planner's path (overlap / flip / keyhole chosen per pass), mask-safe pre-position, deadband
  with the aim point chosen by :func:`tracker.aim.choose_aim`, read-back (integer degrees)
  every 0.5 s cycle; at each deadband D.
* ``gpredict-style``: gtk-rot-ctrl.c: 1 s cycle, a threshold per axis between the current
  target and the read-back, lead = the furthest future point within the threshold
  (bisection), flip only when el max is 180 (``maxel >= 180``), no overlap, targets clamped.
* ``satnogs-style`` (:func:`fly_satnogs`): satnogs-client's rotator worker: 3 s cycle, a fixed
  threshold per axis between where the satellite is now and the read-back, no lead, plain
  0-360 azimuth, and above a set culmination elevation (75 deg) the second half of the pass
  mirrored about the culmination point so the antenna goes over the top.

Per deadband D, for the stream policy: lost-track seconds (error > 5 deg while up; all passes
and the ones not ruled out: every pass some deadband flew without loss, and every other one
unless the bound over every mount branch, :func:`any_branch_bound`, shows that no schedule
keeps it within 5 deg (the bound can rule a pass out, never prove it followable), the share of
passes whose max error is within D and within D + 0.25, max and p99 great-circle error over all
visible time (sampled every 0.25 s), motor starts per pass, and two clairvoyant references: the
lower bound on starts (:func:`start_bound`, tracker/startbound.py: no schedule on the planner's
branch, knowing the future, keeps the great-circle error within D with fewer starts from park)
with its CPU time per pass, and a whole-pass joint schedule that keeps it within D
(:func:`joint_starts`, tracker/schedule.py: a schedule that exists, not a bound). Every policy
that kept a pass within D is checked against the bound on that pass (a pass where it needed
fewer starts would prove the bound wrong: counted as "below bound"). Beside it the two peers,
each tuned to the stream policy's p99 error at that D (the largest threshold whose p99 is
within it, :class:`PeerTuner`), with their starts. Each stream pass with lost seconds is listed
with the planner's predicted loss and what :func:`any_branch_bound` at the lost-track limit
says: on which branch a schedule could follow it, or that none can. ``--hard`` flies only the
passes every exact path (normal, overlap, flip) loses, the ones that need a keyhole, an ahead
path or an unwind: the 7-day suite's hard passes in minutes, ``--days 7 --max-sats 0 --sample 0
--hard``. CPU time (summed over the workers) is printed beside wall time. The decision cost per
cycle alone: benchmarks/decision_cost.py.
"""

from __future__ import annotations

import argparse
import multiprocessing
import resource
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from passsuite import pass_suite, sample_suite

import tracker.stream as stream_mod
from tracker import compiled
from tracker.aim import gpredict_aim
from tracker.fewest_starts import fewest_starts
from tracker.geometry import MountPath, pointing_error_deg
from tracker.mount import AxisMotor, MotorModel, drive_axis, preset
from tracker.planner import gpredict_plan, plan_pass
from tracker.startbound import start_lower_bound, start_lower_bound_any_branch
from tracker.stream import StreamSettings, TrackCore, pass_window

LOST_DEG = 5.0
SAMPLE_S = 0.25


def _readback(truth: MotorModel, t: float) -> tuple[float, float]:
    az, el = truth.position(t)
    return float(round(az)), float(round(el))


class CycleMeter:
    """CPU time of the live loop's per-cycle work (what :func:`tracker.stream.run_pass` asks
    of :class:`TrackCore` each cycle: observe, decide, commanded, status), over cycles. The
    whole-pass schedule is planned within one decision, once a pass: its CPU time is counted
    apart (:meth:`planning_apart`), not as per-cycle work."""

    def __init__(self) -> None:
        self.cpu_ns = 0
        self.cycles = 0
        self.plan_ns = 0
        self.plans = 0

    @property
    def us_per_cycle(self) -> float:
        return self.cpu_ns / 1000.0 / max(self.cycles, 1)

    @contextmanager
    def planning_apart(self):
        real = stream_mod.plan_schedule

        def timed(*args, **kwargs):
            c0 = time.thread_time_ns()
            try:
                return real(*args, **kwargs)
            finally:
                spent = time.thread_time_ns() - c0
                self.plan_ns += spent
                self.cpu_ns -= spent
                self.plans += 1

        stream_mod.plan_schedule = timed
        try:
            yield
        finally:
            stream_mod.plan_schedule = real


def fly_stream(track, spec, station, deadband_deg: float, cycle_s: float = 0.5,
               meter: CycleMeter | None = None, planned: bool = True):
    """The live loop's decisions against a simulated rotator; returns (cmd_t, az, el), plan.

    With ``meter`` the core's per-cycle calls (and the status the live loop shows each cycle)
    are timed in CPU time; the commands are the same either way. ``planned``: with the
    whole-pass schedule (StreamSettings.planned_schedule) as ``tracker track`` runs, else the
    aim policy alone."""
    plan = plan_pass(track, spec, station, current=(spec.park_az_deg, spec.park_el_deg))
    core = TrackCore(plan, track, spec, station,
                     StreamSettings(deadband_deg=deadband_deg, cycle_s=cycle_s,
                                    planned_schedule=planned))
    t = min(core.preposition_t_s, float(track.t_s[0])) - cycle_s
    truth = MotorModel(spec, spec.park_az_deg, spec.park_el_deg, t)
    with meter.planning_apart() if meter is not None else nullcontext():
        cmds, t = _fly(core, truth, t, cycle_s, meter)
    return cmds, plan, t


def _fly(core: TrackCore, truth: MotorModel, t: float, cycle_s: float,
         meter: CycleMeter | None) -> tuple[list, float]:
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
    return cmds, t


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


def _pass_axes(track, spec, station):
    """The planner's path over AOS..LOS: (path, times, az, el, the azimuth's weight cos el)."""
    plan = plan_pass(track, spec, station, current=(spec.park_az_deg, spec.park_el_deg))
    path = MountPath.exact_from_plan(plan, None, spec)
    aos_s, los_s = pass_window(track, station)
    ts = np.arange(aos_s, los_s + 1e-9, SAMPLE_S)
    if len(ts) < 2:
        return None
    az, el = path.mount_at(ts)
    return path, ts, az, el, np.abs(np.cos(np.radians(el)))


def start_bound(track, spec, station, bound_deg: float) -> int | None:
    """The clairvoyant lower bound on motor starts from park (rotator at rest on park before
    the pass) for a great-circle error within ``bound_deg`` at every sample AOS..LOS, on the
    planner's branch (:func:`tracker.startbound.start_lower_bound`; its docstring has the
    proof). None: no schedule on that branch keeps the bound."""
    axes = _pass_axes(track, spec, station)
    if axes is None:
        return 0
    _path, ts, az, el, _w = axes
    bearing, target_el = track.direction_at(ts)
    return start_lower_bound(spec, ts, bearing, target_el, az, el, bound_deg,
                             park=(spec.park_az_deg, spec.park_el_deg))


def any_branch_bound(track, spec, station, bound_deg: float) -> tuple[int, str] | None:
    """:func:`start_bound` over every mount branch (upright or over the top, every turn,
    either side of the culmination: :func:`tracker.startbound.start_lower_bound_any_branch`):
    a lower bound on the starts of any schedule whatsoever that keeps ``bound_deg`` over
    AOS..LOS, with the branch where the relaxed model keeps it; None when no schedule can (the
    rotator cannot follow the pass within it)."""
    aos_s, los_s = pass_window(track, station)
    ts = np.arange(aos_s, los_s + 1e-9, SAMPLE_S)
    if len(ts) < 2:
        return 0, "any"
    bearing, target_el = track.direction_at(ts)
    return start_lower_bound_any_branch(spec, ts, bearing, target_el, bound_deg,
                                        park=(spec.park_az_deg, spec.park_el_deg))


def joint_starts(track, spec, station, bound_deg: float) -> int | None:
    """Motor starts of :func:`tracker.fewest_starts.fewest_starts` (great-circle error within
    ``bound_deg`` over AOS..LOS) from park: each axis may first move to any whole degree for
    one start before AOS, as the bound allows. None when no schedule of its class keeps the
    bound."""
    axes = _pass_axes(track, spec, station)
    if axes is None:
        return 0
    path, ts, _az, _el, _w = axes
    motor = MotorModel(spec, spec.park_az_deg, spec.park_el_deg, float(ts[0]))
    found = fewest_starts(path, motor.az, motor.el, float(ts[0]), float(ts[-1]), bound_deg,
                          free_start=True)
    return None if found is None else found.starts


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


def fly_satnogs(track, spec, station, threshold_deg: float = 4.0, cycle_s: float = 3.0,
                flip_el_deg: float | None = 75.0, t_start: float | None = None):
    """A SatNOGS-client-style loop: every ``cycle_s`` it reads the rotator back and, when
    either axis is more than ``threshold_deg`` from where the satellite is *now* (no lead),
    sends that position. Azimuth is a plain 0-360 bearing (no overlap). With a flip elevation
    and a pass culminating at or above it, positions after culmination are mirrored about the
    culmination point (azimuth and elevation alike, elevation running past 90), so the
    antenna goes over the top instead of swinging round. Returns the commands (t, az, el)."""
    _aos_s, los_s = pass_window(track, station)
    t = float(track.t_s[0]) if t_start is None else t_start
    truth = MotorModel(spec, spec.park_az_deg, spec.park_el_deg, t)
    k = int(np.argmax(track.el_deg))
    tca_s, az_tca, el_tca = (float(track.t_s[k]), float(track.az_deg[k]),
                             float(track.el_deg[k]))
    flip = flip_el_deg is not None and el_tca >= flip_el_deg and spec.el_max_deg >= 180
    res = spec.resolution_deg
    cmds = []
    while t <= los_s:
        az_t, el_t = track.direction_at(np.array([t]))
        az, el = float(az_t[0]), float(el_t[0])
        if flip and t >= tca_s:
            az, el = (2.0 * az_tca - az) % 360.0, 2.0 * el_tca - el
        rot_az, rot_el = _readback(truth, t)
        if abs(az - rot_az % 360.0) > threshold_deg or abs(el - rot_el) > threshold_deg:
            m = float(spec.frame.mech_of(az))
            c_az = min(max(round(m / res) * res, 0.0), spec.az_span_deg)
            c_el = min(max(round(el / res) * res, spec.el_min_deg), spec.el_max_deg)
            truth.command(c_az, c_el, t)
            cmds.append((t, c_az, c_el))
        t += cycle_s
    return cmds


def _fly_gpredict_cmds(track, spec, station, threshold_deg, t_start):
    return fly_gpredict(track, spec, station, threshold_deg=threshold_deg, t_start=t_start)[0]


def _fly_satnogs_cmds(track, spec, station, threshold_deg, t_start):
    return fly_satnogs(track, spec, station, threshold_deg=threshold_deg, t_start=t_start)


PEERS = {"gpredict-style": _fly_gpredict_cmds, "satnogs-style": _fly_satnogs_cmds}
THRESHOLDS_DEG = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0)


def summarise(rows: list[dict], followable: np.ndarray, deadband_deg: float) -> dict:
    """Error, loss and starts of one policy over the passes of ``rows``."""
    err = np.concatenate([r["err"] for r in rows])
    per_max = np.array([r["err"].max() for r in rows])
    lost = np.array([r["lost_s"] for r in rows])
    n = len(rows)
    return {"max": float(err.max()), "p99": float(np.percentile(err, 99)),
            "lost_s": float(lost.sum()), "lost_followable_s": float(lost[followable].sum()),
            "passes_lost": int(np.sum(lost > 0)),
            "in_db": float(np.mean(per_max <= deadband_deg + 1e-9)),
            "in_db25": float(np.mean(per_max <= deadband_deg + 0.25 + 1e-9)),
            "starts": sum(r["starts"] for r in rows), "starts_pp": sum(
                r["starts"] for r in rows) / n,
            "per_pass_starts": np.array([r["starts"] for r in rows]), "per_pass_max": per_max}


class PeerTuner:
    """One peer policy flown over the suite at any threshold (each threshold once), and the
    largest threshold whose p99 error is within a given one."""

    def __init__(self, name: str, passes: PassMap, spec, t_starts: list[float],
                 followable: np.ndarray):
        self.name, self.passes, self.spec = name, passes, spec
        self.t_starts, self.followable = t_starts, followable
        self.rows: dict[float, list[dict]] = {}
        self.cpu_s = 0.0

    def flown(self, threshold_deg: float) -> list[dict]:
        if threshold_deg not in self.rows:
            got = self.passes.map(_fly_peer_pass, [(self.spec, self.name, threshold_deg, t0)
                                                   for t0 in self.t_starts])
            self.rows[threshold_deg] = [row for row, _cpu in got]
            self.cpu_s += sum(cpu for _row, cpu in got)
        return self.rows[threshold_deg]

    def p99(self, threshold_deg: float) -> float:
        return float(np.percentile(np.concatenate([r["err"] for r in self.flown(
            threshold_deg)]), 99))

    def tuned(self, p99_deg: float, deadband_deg: float, refine: int = 2) -> tuple[float, dict]:
        """(threshold, summary): the largest threshold with p99 <= ``p99_deg`` (the grid,
        then ``refine`` bisections toward the next grid value); the smallest grid threshold
        when none is."""
        grid = [th for th in THRESHOLDS_DEG]
        ok = [th for th in grid if self.p99(th) <= p99_deg]
        if not ok:
            th = grid[0]
        else:
            th = max(ok)
            above = [g for g in grid if g > th]
            if above:
                lo, hi = th, above[0]
                for _ in range(refine):
                    mid = round(0.5 * (lo + hi), 4)
                    lo, hi = (mid, hi) if self.p99(mid) <= p99_deg else (lo, mid)
                th = lo
        return th, summarise(self.flown(th), self.followable, deadband_deg)


EL_CLASSES_DEG = ((0.0, 10.0), (10.0, 45.0), (45.0, 90.1))


def _by_elevation(suite, ours: np.ndarray, bounds: list, joint: list) -> list[tuple]:
    """Per max-elevation class: (lo, hi, passes, our starts over the bound, the joint
    schedule's over the bound), on the passes where both references exist (nan: none)."""
    max_el = np.array([sp.meta["max_el_deg"] for sp in suite])
    b = np.array([np.nan if x is None else x for x in bounds], dtype=float)
    j = np.array([np.nan if x is None else x for x in joint], dtype=float)
    out = []
    for lo, hi in EL_CLASSES_DEG:
        sel = (max_el >= lo) & (max_el < hi) & np.isfinite(b) & (b > 0)
        both = sel & np.isfinite(j)
        out.append((lo, hi, int(sel.sum()),
                    float(ours[sel].sum() / b[sel].sum()) if sel.any() else float("nan"),
                    float(j[both].sum() / b[both].sum()) if both.any() else float("nan")))
    return out


# Flying passes in parallel -------------------------------------------------------------------
# Every pass is flown on its own, so the suite's passes can be shared among worker processes;
# results come back in the suite's order, the same as flown in one process.

# The suite of the PassMap a forked worker was started for (tasks name passes by index).
_WORKER_SUITE: list = []


def _set_worker_suite(suite: list, kernels: str | None = None) -> None:
    global _WORKER_SUITE
    _WORKER_SUITE = suite
    if kernels is not None:
        compiled.use(kernels)


def _on_pass(task: tuple):
    fn, i, args = task
    return fn(_WORKER_SUITE[i], *args)


class PassMap:
    """``map(fn, args)``: ``[fn(suite[i], *args[i]) ...]`` over the suite's passes, in order,
    in ``workers`` processes (1: in this one). :meth:`close` ends the workers; their CPU
    time is then in :func:`cpu_s_with_children`."""

    def __init__(self, suite: list, workers: int = 1):
        self.suite = suite
        self.pool: ProcessPoolExecutor | None = None
        if workers > 1 and len(suite) > 1:
            # A forked worker inherits the suite; elsewhere each gets a copy once.
            fork = "fork" in multiprocessing.get_all_start_methods()
            ctx = multiprocessing.get_context("fork" if fork else "spawn")
            if fork:
                _set_worker_suite(suite)
            self.pool = ProcessPoolExecutor(
                workers, mp_context=ctx, initializer=None if fork else _set_worker_suite,
                initargs=() if fork else (suite, compiled.backend()))
            self.chunk = max(1, len(suite) // (8 * workers))

    def map(self, fn, args: list[tuple]) -> list:
        if self.pool is None:
            return [fn(sp, *a) for sp, a in zip(self.suite, args, strict=True)]
        tasks = [(fn, i, a) for i, a in enumerate(args)]
        return list(self.pool.map(_on_pass, tasks, chunksize=self.chunk))

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown()
            self.pool = None
            _set_worker_suite([])


def cpu_s_with_children() -> float:
    """CPU time of this process and of its ended worker processes."""
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


def _fly_pass(sp, spec, deadbands: list[float], schedule: bool) -> dict:
    """One pass flown by the stream policy at each deadband (and with the whole-pass
    schedule): the measured rows, their CPU time, and the pass if it lost track."""
    tr, st = sp.track, sp.station
    out: dict = {"rows": {}, "cpu": {}, "sched_rows": {}, "sched_cpu": {}, "lossy": []}
    lossy_at = []
    for d in deadbands:
        c0 = time.process_time()
        cmds, plan, _t = fly_stream(tr, spec, st, d)
        t_start = min(plan.preposition_t_s, float(tr.t_s[0])) - 0.5
        row = out["rows"][d] = measure(tr, spec, st, cmds, t_start)
        out["cpu"][d] = time.process_time() - c0
        if schedule:
            c0 = time.process_time()
            acmds, _plan, _t = fly_stream(tr, spec, st, d, planned=False)
            out["sched_rows"][d] = measure(tr, spec, st, acmds, t_start)
            out["sched_cpu"][d] = time.process_time() - c0
        if row["lost_s"] > 0:
            lossy_at.append((d, row["lost_s"]))
    # Not ruled out: a deadband flown without loss shows a schedule that keeps the lost-track
    # limit; otherwise only the bound over every branch can rule the pass out (None), and a
    # pass it does not rule out counts as followable, so its losses count against the loop.
    witness = any(out["rows"][d]["lost_s"] == 0 for d in deadbands)
    reach = None if witness or not lossy_at else any_branch_bound(tr, spec, st, LOST_DEG)
    out["followable"] = witness or reach is not None
    out["planner_followable"] = plan.lost_track_s == 0
    for d, lost_s in lossy_at:
        out["lossy"].append((f"stream D={d:g}", sp.meta["target"], sp.meta["station"],
                             sp.meta["max_el_deg"], lost_s, float(plan.lost_track_s),
                             "flown" if witness else reach))
    out["t_start"] = t_start
    return out


def _fly_peer_pass(sp, spec, name: str, threshold_deg: float, t_start: float
                   ) -> tuple[dict, float]:
    """One pass flown by a peer policy at one threshold: its measured row and CPU time."""
    c0 = time.process_time()
    cmds = PEERS[name](sp.track, spec, sp.station, threshold_deg, t_start)
    row = measure(sp.track, spec, sp.station, cmds, t_start)
    return row, time.process_time() - c0


def _pass_bound(sp, spec, deadband_deg: float, wanted: bool = True
                ) -> tuple[int | None, float]:
    """:func:`start_bound` of one pass (from park) at one deadband, and its CPU time (None
    and 0 when not ``wanted``)."""
    if not wanted:
        return None, 0.0
    c0 = time.process_time()
    return start_bound(sp.track, spec, sp.station, deadband_deg), time.process_time() - c0


def _pass_joint(sp, spec, deadband_deg: float, joint: bool) -> int | None:
    """:func:`joint_starts` of one pass at one deadband (None without ``joint``)."""
    return joint_starts(sp.track, spec, sp.station, deadband_deg) if joint else None


def _below_bound(r: dict, joint: list, bounds: list, deadband_deg: float,
                 computed: np.ndarray) -> dict:
    """Per policy: (passes it kept within the deadband, passes among them where it made fewer
    starts than the bound or the bound called it impossible), over the passes whose bound
    was ``computed``. Any of the latter would prove the bound wrong."""
    b = np.array([np.inf if x is None else x for x in bounds], dtype=float)
    within = (r["per_pass_max"] <= deadband_deg + 1e-9) & computed
    out = {"stream": (int(within.sum()), int(np.sum(within & (r["per_pass_starts"] < b))))}
    if "schedule" in r:
        a = r["schedule"]
        w = (a["per_pass_max"] <= deadband_deg + 1e-9) & computed
        out["stream+schedule"] = (int(w.sum()), int(np.sum(w & (a["per_pass_starts"] < b))))
    j = np.array([np.nan if x is None else x for x in joint], dtype=float)
    has = np.isfinite(j) & computed
    out["joint schedule"] = (int(has.sum()), int(np.sum(has & (j < b))))
    for name, (_th, pr) in r["peers"].items():
        w = (pr["per_pass_max"] <= deadband_deg + 1e-9) & computed
        out[name] = (int(w.sum()), int(np.sum(w & (pr["per_pass_starts"] < b))))
    return out


def compare(suite, spec, deadbands: list[float], peers: bool = True, joint: bool = True,
            schedule: bool = False, workers: int = 1, bound_every: int = 1) -> dict:
    """Fly every pass of ``suite`` with the stream policy at each deadband; per deadband the
    clairvoyant bound and (``joint``) the joint schedule's starts, and (``peers``) each peer policy
    tuned to the stream policy's p99 error. Returns a result per deadband plus the lossy
    stream passes (policy, target, station, max el, lost s, planner-predicted lost s,
    whether :func:`start_bound` finds any schedule able to keep within the lost-track limit).
    ``workers`` processes share the passes (the same results as one). The bound is computed
    on every ``bound_every``-th pass (its figures and checks are over those)."""
    passes = PassMap(suite, workers)
    try:
        return _compare(suite, spec, deadbands, peers, joint, schedule, passes,
                        max(1, bound_every))
    finally:
        passes.close()


def _compare(suite, spec, deadbands: list[float], peers: bool, joint: bool, schedule: bool,
             passes: PassMap, bound_every: int) -> dict:
    """:func:`compare` with the passes flown through ``passes``."""
    rows: dict[float, list] = {d: [] for d in deadbands}
    cpu = dict.fromkeys(deadbands, 0.0)
    sched_rows: dict[float, list] = {d: [] for d in deadbands}
    sched_cpu = dict.fromkeys(deadbands, 0.0)
    followable, planner_followable, t_starts, lossy = [], [], [], []
    for flown in passes.map(_fly_pass, [(spec, deadbands, schedule)] * len(suite)):
        for d in deadbands:
            rows[d].append(flown["rows"][d])
            cpu[d] += flown["cpu"][d]
            if schedule:
                sched_rows[d].append(flown["sched_rows"][d])
                sched_cpu[d] += flown["sched_cpu"][d]
        lossy += flown["lossy"]
        followable.append(flown["followable"])
        planner_followable.append(flown["planner_followable"])
        t_starts.append(flown["t_start"])
    followable = np.array(followable)
    tuners = {name: PeerTuner(name, passes, spec, t_starts, followable)
              for name in (PEERS if peers else ())}
    out: dict = {"deadbands": {}, "lossy": lossy, "followable": followable, "cpu": cpu,
                 "planner_followable": int(np.sum(planner_followable)),
                 "bound_every": bound_every}
    computed = np.arange(len(suite)) % bound_every == 0
    for d in deadbands:
        r = summarise(rows[d], followable, d)
        r["cpu_s"] = cpu[d]
        timed = passes.map(_pass_bound, [(spec, d, bool(c)) for c in computed])
        bounds = [b for b, _cpu in timed]
        r["bound_cpu_pp"] = sum(c for _b, c in timed) / max(int(computed.sum()), 1)
        feasible = np.array([b is not None for b in bounds]) & computed
        r["bound_pp"] = float(np.mean([b for b in bounds if b is not None])) if any(
            feasible) else float("nan")
        r["stream_feasible_pp"] = float(np.mean(r["per_pass_starts"][feasible])) if any(
            feasible) else float("nan")
        r["bound_passes"] = int(feasible.sum())
        refs = passes.map(_pass_joint, [(spec, d, joint)] * len(suite))
        ok = np.array([x is not None for x in refs]) & feasible
        r["joint_pp"] = float(np.mean([x for x, f in zip(refs, ok, strict=True) if f])) \
            if ok.any() else float("nan")
        r["stream_joint_pp"] = float(np.mean(r["per_pass_starts"][ok])) if ok.any() \
            else float("nan")
        r["by_el"] = _by_elevation(suite, r["per_pass_starts"], bounds, refs)
        if schedule:
            a = summarise(sched_rows[d], followable, d)
            a["cpu_s"] = sched_cpu[d]
            a["x_bound"] = float(np.mean(a["per_pass_starts"][feasible])) / r["bound_pp"] \
                if any(feasible) else float("nan")
            r["schedule"] = a
        r["peers"] = {name: tu.tuned(r["p99"], d) for name, tu in tuners.items()}
        r["below_bound"] = _below_bound(r, refs, bounds, d, computed)
        out["deadbands"][d] = r
    out["peer_cpu"] = {name: tu.cpu_s for name, tu in tuners.items()}
    return out


def print_results(res: dict, n_passes: int) -> None:
    """Per deadband: our loop, the clairvoyant bound, and the peers tuned to our p99."""
    followable = res["followable"]
    print(f"\npasses: {n_passes}; not ruled out within {LOST_DEG:g} deg (flown without loss "
          f"at some deadband, or the bound over every branch does not rule them out; losses on "
          f"them count as 'lost fol.'): {int(followable.sum())}; the planner predicts no loss on "
          f"{res['planner_followable']}")
    print("\nstream policy (tracker.stream.TrackCore + tracker.aim, as tracker track runs it), "
          "per deadband:")
    print(f"{'D deg':>6}{'lost s':>8}{'lost fol.':>10}{'in D %':>8}{'in D+.25%':>10}"
          f"{'max':>7}{'p99':>7}{'starts/pass':>12}{'bound':>7}{'x bound':>8}"
          f"{'joint':>7}{'x joint':>8}{'cpu s':>7}{'bound cpu s/pass':>17}")
    for d, r in res["deadbands"].items():
        print(f"{d:>6g}{r['lost_s']:>8.1f}{r['lost_followable_s']:>10.1f}"
              f"{100 * r['in_db']:>8.1f}{100 * r['in_db25']:>10.1f}{r['max']:>7.2f}"
              f"{r['p99']:>7.2f}{r['starts_pp']:>12.1f}{r['bound_pp']:>7.1f}"
              f"{r['stream_feasible_pp'] / r['bound_pp']:>8.2f}{r['joint_pp']:>7.1f}"
              f"{r['stream_joint_pp'] / r['joint_pp']:>8.2f}{r['cpu_s']:>7.1f}"
              f"{r['bound_cpu_pp']:>17.2f}")
    every = res["bound_every"]
    print("bound: the clairvoyant lower bound on starts per pass from park for a great-circle "
          "error within D (tracker.startbound; passes where it is feasible"
          + (f", on one pass in {every}" if every > 1 else "") + "); joint: a "
          "whole-pass schedule knowing the future that keeps the great-circle error within D "
          "(tracker.schedule; a schedule that exists, not a bound); x: our starts on the same "
          "passes over it")
    print("the bound checked against every policy on every pass it kept within D "
          "(passes within D / passes with fewer starts than the bound: must be 0):")
    for d, r in res["deadbands"].items():
        print(f"  D={d:g}: " + "; ".join(f"{name} {n} / {bad}"
                                        for name, (n, bad) in r["below_bound"].items()))
    if any("schedule" in r for r in res["deadbands"].values()):
        print("the aim policy alone (StreamSettings(planned_schedule=False)), same run:")
        for d, r in res["deadbands"].items():
            a = r["schedule"]
            print(f"{d:>6g}{a['lost_s']:>8.1f}{a['lost_followable_s']:>10.1f}"
                  f"{100 * a['in_db']:>8.1f}{100 * a['in_db25']:>10.1f}{a['max']:>7.2f}"
                  f"{a['p99']:>7.2f}{a['starts_pp']:>12.1f}{r['bound_pp']:>7.1f}"
                  f"{a['x_bound']:>8.2f}{'':>15}{a['cpu_s']:>7.1f}   "
                  f"starts with/without {a['starts_pp'] / r['starts_pp']:.3f}")
    print("starts over the bound by max elevation (ours | the joint schedule's):")
    for d, r in res["deadbands"].items():
        print(f"  D={d:g}: " + "; ".join(
            f"{lo:g}-{min(hi, 90):g} deg ({n}): {mine:.2f} | {ref:.2f}"
            for lo, hi, n, mine, ref in r["by_el"]))
    peers = [n for n in PEERS if any(n in r["peers"] for r in res["deadbands"].values())]
    if peers:
        print("\npeer policies tuned to the stream policy's p99 error (largest threshold "
              "whose p99 is within it):")
        print(f"{'D deg':>6}{'policy':>16}{'thr deg':>9}{'p99':>7}{'max':>7}{'lost s':>8}"
              f"{'lossy':>6}{'in D+.25%':>10}{'starts/pass':>12}{'ours x':>8}")
        for d, r in res["deadbands"].items():
            for name in peers:
                th, pr = r["peers"][name]
                print(f"{d:>6g}{name:>16}{th:>9.3g}{pr['p99']:>7.2f}{pr['max']:>7.2f}"
                      f"{pr['lost_s']:>8.1f}{pr['passes_lost']:>6}{100 * pr['in_db25']:>10.1f}"
                      f"{pr['starts_pp']:>12.1f}{r['starts_pp'] / pr['starts_pp']:>8.2f}")
        print("a peer whose p99 stays above ours at its smallest threshold (0.5 deg) shows "
              "that threshold: its p99 is set by the passes it loses (lossy: passes with "
              "error > 5 deg), e.g. a 0/360 crossing swung round without the overlap")
        print("cpu s per peer (all thresholds flown): " + ", ".join(
            f"{k} {v:.1f}" for k, v in res["peer_cpu"].items()))
    for name, target, station, max_el, lost_s, plan_lost_s, reach in res["lossy"]:
        why = ("the planner predicts loss too" if plan_lost_s > 0 else
               "FOLLOWABLE by the planner's prediction")
        bound = ("flown without loss at another deadband" if reach == "flown"
                 else f"RULED OUT: no schedule on any branch keeps within {LOST_DEG:g} deg"
                 if reach is None else
                 f"NOT RULED OUT: the relaxed model keeps it {reach[1]} (at least {reach[0]} "
                 f"starts)")
        print(f"  lossy {name}: {target} from {station}, max el {max_el:.1f}: lost "
              f"{lost_s:.2f} s; planner predicts {plan_lost_s:.1f} s ({why}); clairvoyant "
              f"bound: {bound}")
    print()
    for d, r in res["deadbands"].items():
        reached = [r["lost_followable_s"] == 0, r["in_db25"] >= 0.99,
                   r["stream_feasible_pp"] <= 1.15 * r["bound_pp"]]
        print(f"D={d:g}: 0 lost s on passes not ruled out: {'yes' if reached[0] else 'NO'}; "
              f">= 99 % within D+0.25: {'yes' if reached[1] else 'NO'} "
              f"({100 * r['in_db25']:.1f} %); starts <= 1.15x bound: "
              f"{'yes' if reached[2] else 'NO'} "
              f"({r['stream_feasible_pp'] / r['bound_pp']:.2f}x)")


def hard_passes(suite: list, spec) -> list:
    """The passes of ``suite`` where every exact path (normal, overlap, flip) planned from
    park loses the target: those that need a keyhole, an ahead path or an unwind."""
    park = (spec.park_az_deg, spec.park_el_deg)
    exact = ("normal", "overlap", "flip")
    return [sp for sp in suite
            if min(c.lost_track_s for c in plan_pass(sp.track, spec, sp.station,
                                                     current=park).candidates
                   if c.mode in exact) > 0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=float, default=1.0)
    ap.add_argument("--max-sats", type=int, default=30,
                    help="satellites per group (0 = all)")
    ap.add_argument("--deadband", type=float, nargs="+", default=[2.0, 3.0, 4.0, 5.0],
                    help="deadbands (great-circle deg) to run the stream policy at")
    ap.add_argument("--rotator", default="G-5500")
    ap.add_argument("--mains-hz", type=int, default=50, choices=(50, 60))
    ap.add_argument("--overhead", type=int, default=24)
    ap.add_argument("--sample", type=int, default=100,
                    help="fly only this many passes spread evenly over the suite (0 = all)")
    ap.add_argument("--no-peers", action="store_true",
                    help="skip the peer policies (Gpredict-style, SatNOGS-style)")
    ap.add_argument("--aim-only", action="store_true",
                    help="also fly the live loop without the whole-pass schedule: the ratio")
    ap.add_argument("--no-joint", action="store_true",
                    help="skip the clairvoyant joint schedule (the costliest reference)")
    ap.add_argument("--hard", action="store_true",
                    help="fly only the passes every exact path (normal, overlap, flip) loses: "
                         "those that need a keyhole, an ahead path or an unwind")
    ap.add_argument("--bound-every", type=int, default=1, metavar="N",
                    help="compute the clairvoyant bound on every N-th pass only (its "
                         "figures and checks are over those)")
    ap.add_argument("--workers", type=int, default=1,
                    help="fly the passes in this many processes (the same results as 1)")
    ap.add_argument("--kernels", choices=("best", "numba", "numpy"), default="best",
                    help="the whole-pass programme's implementation (the same schedules; "
                         "best: numba when it runs here)")
    args = ap.parse_args(argv)
    compiled.use(compiled.best() if args.kernels == "best" else args.kernels)
    spec = preset(args.rotator, args.mains_hz)
    t0 = time.perf_counter()
    suite = pass_suite(days=args.days, max_sats=args.max_sats or None,
                       n_overhead=args.overhead)
    if args.sample:
        print(f"sample: {min(args.sample, len(suite))} of {len(suite)} passes, evenly spread")
        suite = sample_suite(suite, args.sample)
    if args.hard:
        n_all, c0 = len(suite), time.process_time()
        suite = hard_passes(suite, spec)
        print(f"hard: {len(suite)} of {n_all} passes that every exact path loses (planned in "
              f"{time.process_time() - c0:.0f} s CPU)")
    print(f"kernels: {compiled.backend()}")
    print(f"rotator {spec.name}: az {spec.az_rate_deg_s:.2f} deg/s, el "
          f"{spec.el_rate_deg_s:.2f} deg/s, start delay {spec.start_delay_s:g} s, span "
          f"{spec.az_span_deg:g}, el max {spec.el_max_deg:g}")
    real = sum(sp.meta["kind"] == "real" for sp in suite)
    print(f"suite: {real} real passes ({args.days:g} d, {args.max_sats or 'all'} sats/group, "
          f"3 stations) + {len(suite) - real} forced overhead; built in "
          f"{time.perf_counter() - t0:.1f} s")
    c0, w0 = cpu_s_with_children(), time.perf_counter()
    res = compare(suite, spec, args.deadband, peers=not args.no_peers,
                  joint=not args.no_joint, schedule=args.aim_only, workers=args.workers,
                  bound_every=args.bound_every)
    print_results(res, len(suite))
    print(f"took {time.perf_counter() - w0:.0f} s wall, {cpu_s_with_children() - c0:.0f} s CPU "
          f"(summed over {max(args.workers, 1)} worker{'s' if args.workers > 1 else ''})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
