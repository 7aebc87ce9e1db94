"""A whole-pass command schedule for the live loop, planned before AOS (numpy, no I/O).

The aim policy (:mod:`tracker.aim`) decides one move at a time. The pass is known in advance,
so the moves can be planned over the whole pass instead, knowing the future:

* :func:`axis_schedule`: one axis, greedily: hold until its error would leave its budget,
  command as late as the loop's cycle allows, to the integer target held longest.
* :func:`plan_schedule`: both axes, keeping the *great-circle* error within the deadband.
  That error is close to ``sqrt(e_az^2 + e_el^2)`` (``e_az`` = azimuth error times cos el),
  so the axes share the deadband: the axis planned first gets a fixed share of it, the
  second at every instant what the first leaves, then each is re-planned within what the
  other now leaves. Both orders and a few shares are tried; every candidate is driven
  through THE motor model (:func:`tracker.mount.drive_axis`) and checked against the real
  target; the fewest motor starts win.

With ``StreamSettings.planned_schedule``, :class:`tracker.stream.TrackCore` follows a
:class:`PassSchedule` while the read-back agrees with it, and hands the rest of the pass to
the aim policy when it does not. The streaming
benchmark uses the same functions for its clairvoyant references (benchmarks/streaming.py).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from tracker.geometry import MountPath
from tracker.mount import AxisMotor, drive_axis
from tracker.skytrack import interp1

# Shares of the deadband tried for the axis planned first.
SHARES = (0.3, 0.5, 0.7, 0.9)
# Integer targets tried around the path where an axis leaves its budget.
_REACH_DEG = 12
# How far ahead a hold is looked for (later samples are planned by later commands).
_HOLD_HORIZON_S = 300.0


@dataclass(frozen=True)
class PassSchedule:
    """Planned commands: at ``t_s[i]`` send ``az_m_deg[i]`` / ``el_deg[i]`` (mechanical;
    an axis not meant to move keeps its previous target). ``starts`` and
    ``peak_error_deg`` are what the motor model predicts up to ``end_s``, after which the
    schedule has nothing to say; ``expected`` is where it puts the antenna."""

    t_s: tuple[float, ...]
    az_m_deg: tuple[float, ...]
    el_deg: tuple[float, ...]
    starts: int
    peak_error_deg: float
    end_s: float
    sample_t_s: np.ndarray
    az_pos_deg: np.ndarray
    el_pos_deg: np.ndarray

    @cached_property
    def _columns(self) -> tuple[list[float], list[float], list[float]]:
        return self.sample_t_s.tolist(), self.az_pos_deg.tolist(), self.el_pos_deg.tolist()

    def expected(self, t_s: float) -> tuple[float, float]:
        """Where the schedule puts the antenna at ``t_s`` (mechanical az, el); asked once a
        cycle, so on floats (:func:`~tracker.skytrack.interp1`)."""
        t, az, el = self._columns
        return interp1(t_s, t, az), interp1(t_s, t, el)


def axis_schedule(t_s: np.ndarray, path_deg: np.ndarray, weight: np.ndarray,
                  rate_deg_s: float, start_delay_s: float, budget_deg: np.ndarray | float,
                  start_deg: float, cycle_step: int = 2, lo_deg: float = -math.inf,
                  hi_deg: float = math.inf) -> list[tuple[int, float]] | None:
    """Commands ``[(sample index, integer target), ...]`` keeping ``weight * |axis - path|``
    within ``budget_deg`` (per sample or one value) for an axis at rest on ``start_deg`` at
    ``t_s[0]`` (module doc; commands on every ``cycle_step``-th sample, each one after the
    previous move arrived, so each is one motor start). None when the axis cannot keep it."""
    n = len(t_s)
    dt = float(t_s[1] - t_s[0])
    budget = np.broadcast_to(np.asarray(budget_deg, dtype=float), (n,))
    horizon = max(2, round(_HOLD_HORIZON_S / dt))
    i, p = 0, float(start_deg)
    out: list[tuple[int, float]] = []
    while True:
        bad = np.flatnonzero(weight[i:] * np.abs(p - path_deg[i:]) > budget[i:])
        if len(bad) == 0:
            return out
        j = i + int(bad[0])
        qs = np.unique(np.clip(np.arange(math.floor(path_deg[j]) - _REACH_DEG,
                                         math.ceil(path_deg[j]) + _REACH_DEG + 1,
                                         dtype=float), lo_deg, hi_deg))
        best = None
        for k in range(j - j % cycle_step, i - 1, -cycle_step):     # latest command first
            end = min(n, k + horizon)
            step = np.abs(qs - p)
            run = np.clip((t_s[None, k:end] - t_s[k] - start_delay_s) * rate_deg_s, 0.0,
                          step[:, None])
            pos = p + np.sign(qs - p)[:, None] * run
            off = weight[None, k:end] * np.abs(pos - path_deg[None, k:end]) > budget[None, k:end]
            leave = np.where(off.any(axis=1), np.argmax(off, axis=1), end - k) + k
            arrive = t_s[k] + start_delay_s + step / rate_deg_s
            good = (leave >= n) | (t_s[np.minimum(leave, n - 1)] > arrive)
            if good.any():
                q = int(np.argmax(np.where(good, leave, -1)))
                best = (k, float(qs[q]), int(leave[q]), float(arrive[q]))
                break
        if best is None:
            return None
        k, p, left_at, arrive_s = best
        out.append((k, p))
        if left_at >= n:
            return out
        i = min(max(math.ceil((arrive_s - float(t_s[0])) / dt - 1e-9), k + 1), n - 1)


def _drive(commands: list[tuple[int, float]], t_s: np.ndarray, axis: AxisMotor
           ) -> tuple[np.ndarray, int]:
    """Positions over ``t_s`` and motor starts of ``commands`` (on a copy of ``axis``)."""
    if not commands:
        return np.full(len(t_s), float(axis.position(float(t_s[0])))), 0
    return drive_axis(copy.copy(axis), t_s[[k for k, _ in commands]],
                      [q for _, q in commands], t_s)


class _Joint:
    """The two axes of one pass on a common time grid, for :func:`plan_schedule`."""

    def __init__(self, path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor,
                 ts: np.ndarray, band_deg: float):
        self.path, self.ts, self.band_deg = path, ts, band_deg
        az_path, el_opt = path.mount_at(ts)
        el_path = np.zeros_like(ts) if el_opt is None else el_opt
        self.axes: dict[str, tuple[np.ndarray, np.ndarray, AxisMotor]] = {
            "az": (az_path, np.abs(np.cos(np.radians(el_path))), az_axis),
                     "el": (el_path, np.ones_like(ts), el_axis)}

    def plan(self, name: str, budget: np.ndarray | float
             ) -> tuple[list[tuple[int, float]], np.ndarray, int] | None:
        """(commands, positions, starts) of one axis within ``budget``."""
        path_deg, w, axis = self.axes[name]
        cmds = axis_schedule(self.ts, path_deg, w, axis.rate_deg_s, axis.start_delay_s,
                             budget, float(axis.position(float(self.ts[0]))), 2,
                             axis.min_deg, axis.max_deg)
        return None if cmds is None else (cmds, *_drive(cmds, self.ts, axis))

    def left(self, name: str, pos: np.ndarray) -> np.ndarray:
        """What axis ``name`` at ``pos`` leaves of the deadband to the other, per sample."""
        path_deg, w, _axis = self.axes[name]
        return np.sqrt(np.maximum(self.band_deg ** 2 - (w * np.abs(pos - path_deg)) ** 2,
                                  0.0))

    def verified(self, found: dict) -> float | None:
        """The peak great-circle error against the real target, None above the band."""
        peak = float(np.max(self.path.error_deg(self.ts, found["az"][1], found["el"][1])))
        return peak if peak <= self.band_deg + 1e-6 else None

    def candidate(self, first: str, second: str, share: float
                  ) -> tuple[int, float, dict] | None:
        """(starts, peak, plans): ``first`` within ``share`` of the band, ``second`` within what it
        leaves, then each re-planned within what the other now leaves (kept if verified)."""
        a = self.plan(first, share * self.band_deg)
        b = None if a is None else self.plan(second, self.left(first, a[1]))
        if a is None or b is None:
            return None
        found = {first: a, second: b}
        peak = self.verified(found)
        if peak is None:
            return None
        for name, other in ((first, second), (second, first)):
            again = self.plan(name, self.left(other, found[other][1]))
            if again and again[2] < found[name][2]:
                trial = {**found, name: again}
                p = self.verified(trial)
                if p is not None:
                    found, peak = trial, p
        return found["az"][2] + found["el"][2], peak, found


def plan_schedule(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor, t0_s: float,
                  end_s: float, band_deg: float, cycle_s: float = 0.5,
                  shares: tuple[float, ...] = SHARES) -> PassSchedule | None:
    """The schedule with the fewest motor starts from ``t0_s`` (a cycle instant, both axes
    at rest, the antenna within the band) to ``end_s`` that keeps the great-circle error
    within ``band_deg`` (module doc), or None when no candidate keeps it."""
    ts = np.arange(t0_s, min(end_s, path.end_s) + 1e-9, cycle_s / 2.0)
    if len(ts) < 4 or az_axis.moving(t0_s) or el_axis.moving(t0_s):
        return None
    joint = _Joint(path, az_axis, el_axis, ts, band_deg)
    found = [joint.candidate(first, second, share)
             for first, second in (("az", "el"), ("el", "az")) for share in shares]
    ranked = sorted((f for f in found if f is not None), key=lambda f: f[:2])
    if not ranked:
        return None
    starts, peak, plans = ranked[0]
    due: dict[int, list[float | None]] = {}
    for i, name in enumerate(("az", "el")):
        for k, q in plans[name][0]:
            due.setdefault(k, [None, None])[i] = q
    az_t, el_t = float(az_axis.target_deg), float(el_axis.target_deg)
    t_out, az_out, el_out = [], [], []
    for k in sorted(due):
        a, e = due[k]
        az_t = az_t if a is None else a
        el_t = el_t if e is None else e
        t_out.append(float(ts[k]))
        az_out.append(az_t)
        el_out.append(el_t)
    return PassSchedule(tuple(t_out), tuple(az_out), tuple(el_out), starts, peak,
                        float(ts[-1]), ts, plans["az"][1], plans["el"][1])
