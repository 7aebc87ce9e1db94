"""A whole-pass command schedule for the live loop, planned before AOS (numpy, no I/O).

The aim policy (:mod:`tracker.aim`) decides one move at a time. The pass is known in advance,
so the moves can be planned over the whole pass instead, knowing the future:
:func:`plan_schedule` takes the schedule with the fewest motor starts that keeps the
great-circle error within the deadband (:func:`tracker.fewest_starts.fewest_starts`, a
dynamic programme over both axes together), drives it through THE motor model
(:func:`tracker.mount.drive_axis`) with the commands as the live loop sends them, and keeps
it only if the model agrees.

With ``StreamSettings.planned_schedule`` (the default), :class:`tracker.stream.TrackCore`
follows a :class:`PassSchedule` while the read-back agrees with it, and hands the rest of the
pass to the aim policy when it does not. The streaming benchmark uses the same functions for
its clairvoyant references (benchmarks/streaming.py).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from tracker.fewest_starts import FewestStarts, StartsProgramme
from tracker.geometry import MountPath
from tracker.mount import AxisMotor, bends_s, drive_axis
from tracker.skytrack import interp1


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


def plan_schedule(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor, t0_s: float,
                  end_s: float, band_deg: float, cycle_s: float = 0.5,
                  from_s: float | None = None, free_start: bool = False
                  ) -> PassSchedule | None:
    """The schedule with the fewest motor starts from ``t0_s`` (a cycle instant, both axes
    at rest) to ``end_s`` that keeps the great-circle error within ``band_deg`` from
    ``from_s`` (default ``t0_s``) on (module doc), or None when none is found. With
    ``free_start`` the axes may rest anywhere at ``t0_s`` (a pre-position's last move goes
    there): the schedule's ``expected(t0_s)`` is that start.

    The programme keeps the band at half-cycle samples; the schedule is checked between them
    too (every tenth of a cycle, and wherever an axis starts or stops: an axis that arrives
    between two samples may leave the target a little further off there), and where it is
    not kept, planned again (twice at most) within a band narrowed by the excess."""
    within = band_deg
    # Every tenth of a cycle; every fifth of those is a half-cycle sample, where
    # :meth:`PassSchedule.expected` interpolates.
    # Steps counted from t0_s, not from the epoch: np.arange steps by the difference of its
    # first two values, which at epoch seconds is 0.05 s rounded to 0.24 us, and the grid
    # would drift off the loop's cycles by 0.2 ms over a pass.
    fine = t0_s + np.arange(0.0, min(end_s, path.end_s) - t0_s + 1e-9, cycle_s / 10.0)
    kept = fine >= (t0_s if from_s is None else from_s) - 1e-9
    # The graphs searched for the band serve the narrower ones too.
    programme = StartsProgramme(path, az_axis, el_axis, t0_s, end_s, band_deg, cycle_s,
                                free_start)
    for _attempt in range(3):
        found = programme.solve(within, from_s)
        if found is None:
            return None
        got = _followed(found, az_axis, el_axis, t0_s, free_start, fine)
        if got is None:
            return None     # the model disagrees with the programme's own motion
        (t_out, az_out, el_out), starts, ts, az_pos, el_pos = got
        on = ts >= fine[kept][0] if kept.any() else np.zeros(len(ts), dtype=bool)
        peak = float(np.max(path.error_deg(ts[on], az_pos[on], el_pos[on]))) \
            if on.any() else 0.0
        if peak <= band_deg + 1e-6:
            half = np.searchsorted(ts, fine[::5])
            return PassSchedule(t_out, az_out, el_out, starts, peak, float(ts[half[-1]]),
                                ts[half], az_pos[half], el_pos[half])
        within -= peak - band_deg + 0.01
    return None


def _followed(found: FewestStarts, az_axis: AxisMotor, el_axis: AxisMotor, t0_s: float,
              free_start: bool, ts: np.ndarray
              ) -> tuple[tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]], int,
                         np.ndarray, np.ndarray, np.ndarray] | None:
    """``found`` as the loop sends it (times, az, el: each command names both axes, the one
    not meant to move keeps its previous target), its motor starts, and az / el driven
    through the motor model over ``ts`` and every instant within it where an axis starts or
    stops (those times, then the positions); None when the model's starts differ from the
    programme's."""
    moved = 0       # pre-position moves counted in ``found.starts``
    if free_start:
        moved = sum(abs(x - float(a.position(t0_s))) > 1e-9
                    for a, x in ((az_axis, found.start_az_deg), (el_axis, found.start_el_deg)))
        az_axis, el_axis = (AxisMotor(a.min_deg, a.max_deg, a.rate_deg_s, a.start_delay_s,
                                      a.resolution_deg, x, t0_s)
                            for a, x in ((az_axis, found.start_az_deg),
                                         (el_axis, found.start_el_deg)))
    az_t, el_t = float(az_axis.target_deg), float(el_axis.target_deg)
    t_out, az_out, el_out = [], [], []
    for t, a, e in found.commands:
        az_t = az_t if a is None else a
        el_t = el_t if e is None else e
        t_out.append(t)
        az_out.append(az_t)
        el_out.append(el_t)
    bends = np.concatenate((bends_s(az_axis, t_out, az_out), bends_s(el_axis, t_out, el_out)))
    ts = np.union1d(ts, bends[(bends > ts[0]) & (bends < ts[-1])])
    az_pos, starts_az = drive_axis(copy.copy(az_axis), t_out, az_out, ts)
    el_pos, starts_el = drive_axis(copy.copy(el_axis), t_out, el_out, ts)
    if starts_az + starts_el + moved != found.starts:
        return None
    return ((tuple(t_out), tuple(az_out), tuple(el_out)), starts_az + starts_el, ts, az_pos,
            el_pos)
