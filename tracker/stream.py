"""Live tracking: follow a MountPlan on a real (or emulated) rotator.

Two layers, so the decisions can be tested and benchmarked without any port:

* :class:`TrackCore` — pure decision logic. It is fed the time and each read-back, and answers
  what to command (pre-position, a deadband/aim-point move from :mod:`tracker.aim`, park, or
  nothing; where the path needs the motors running most of the time, near the zenith, it
  follows the plan's own led commands). It keeps the loop's belief of the motors in THE motor
  model (:class:`tracker.mount.AxisMotor`), interprets read-back against the commanded mechanical
  position (never trusting read-back alone to tell which side of the overlap the antenna is
  on), and detects stalls and read-back that contradicts the plan.
* :func:`run_pass` — the I/O loop on a :class:`~tracker.clock.Clock`: one request at a time,
  read back every cycle, reconnect with backoff when the port vanishes and resume at the
  current point of the plan, and all-stop on every way out (Ctrl-C, SIGTERM, exceptions).

Works with any :class:`~tracker.protocols.base.RotatorDriver` (``position``/``goto``/``stop``).
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from tracker.aim import COMMAND_COST_STARTS, Aim, choose_aim, needs_command, quiet_until_s
from tracker.clock import Clock
from tracker.errors import (
    PortLostError,
    ProtocolError,
    ReadbackError,
    RotatorIOError,
    RotatorTimeout,
    StallError,
    TrackerError,
)
from tracker.geometry import (
    MountLook,
    MountPath,
    boresight_look,
    look_error_deg,
    mount_look,
    move_clears_mask,
    pointing_enu,
    pointing_error_deg,
    raise_to_mask,
)
from tracker.mount import MotorModel, RotatorSpec
from tracker.planner import safe_moves
from tracker.schedule import PassSchedule, plan_schedule
from tracker.skytrack import SkyTrack, angle_between_deg, interp1_rows
from tracker.stall import AxisWatch, moving_axis, stall_error
from tracker.station import Station

# What TrackCore._planned answers when the aim policy, not the schedule, decides.
_AIM = object()
# The whole-pass schedule keeps the error within the deadband less this (and less the
# target's travel between its samples): rounding room for the read-back's agreement with it
# (the aim policy's ``margin_deg`` also covers its coarser predictions).
SCHEDULE_MARGIN_DEG = 0.02
# A schedule that cannot keep the band through a fast stretch of the path ends this long
# before it, so the aim policy leads the antenna into the stretch.
SCHEDULE_HANDOFF_S = 10.0


class Phase(str, Enum):
    WAIT = "wait"                  # before the pre-position time
    PREPOSITION = "preposition"    # moving to / waiting at the AOS point
    TRACK = "track"                # AOS..LOS: deadband + aim point
    PARK = "park"                  # after LOS, going to park
    DONE = "done"


# The members as module names: on Python 3.11 reading one off the class (``Phase.TRACK``) is a
# descriptor call, about 0.3 us, and the live loop asks several each cycle.
_WAIT, _PREPOSITION, _TRACK, _PARK, _DONE = (Phase.WAIT, Phase.PREPOSITION, Phase.TRACK,
                                             Phase.PARK, Phase.DONE)
# The phase a command of each reason belongs to (TrackCore.commanded).
_PHASE_OF_REASON = {"preposition": _PREPOSITION, "track": _TRACK, "park": _PARK}


@dataclass(frozen=True)
class StreamSettings:
    """Tuning of the live loop; defaults suit a G-5500 behind a GS-232B."""

    deadband_deg: float = 4.0
    cycle_s: float = 0.5
    margin_deg: float = 0.2           # predictions are sampled: keep this inside the deadband
    follow_fraction: float = 0.4      # path faster than this share of a motor: follow the plan
    park_after_pass: bool = True
    stall_travel_deg: float = 2.0     # expected travel with no motion seen → stall
    # A command that moved nothing is sent again this many times before the axis counts as
    # stalled: line noise loses a W now and then, and a W carries no acknowledgement.
    stall_resends: int = 3
    contradiction_deg: float = 20.0   # read-back this far from belief → not trusted
    settle_readings: int = 2          # agreeing read-backs needed after a contradiction
    # Read-back that contradicts itself or the commands for this long (a noisy potentiometer,
    # replies to the wrong command, a second program on the port) ends the run: waiting for
    # it to settle would never move the antenna again, nor end the pass.
    inconsistent_give_up_s: float = 30.0
    reconnect_initial_s: float = 0.5
    reconnect_max_s: float = 2.0      # a USB adapter that comes back is found within ~2 s
    reconnect_give_up_s: float | None = None   # None: keep trying until the pass ends
    timeouts_before_lost: int = 3
    # Unreadable replies show the line is alive (noise, a stray byte): reopening the port
    # rarely helps and costs a second or more, so only a longer run of them counts.
    garbled_before_lost: int = 10
    aim_step_s: float = 0.5
    # Plan the pass's moves before AOS knowing the whole pass (tracker.schedule) and follow
    # them while the read-back agrees; the aim policy decides the rest.
    planned_schedule: bool = True
    park_timeout_s: float = 180.0


@dataclass(frozen=True)
class Command:
    """One move the core wants: mechanical azimuth, elevation (None for az-only)."""

    az_m_deg: float
    el_deg: float | None
    reason: str                      # preposition / track / park / resume
    aim: Aim | None = None
    clamped: str = ""                # non-empty when a limit or the mask changed the target
    resend: int = 0                  # > 0: the n-th copy of the last command (no motion seen)


@dataclass(slots=True)
class Status:
    """Everything a UI shows for one cycle (built anew each cycle, so kept cheap: slots, no
    frozen-instance checks; read it, do not change it)."""

    t_s: float
    phase: Phase
    mode: str
    target_az_deg: float
    target_el_deg: float
    antenna_az_m_deg: float | None
    antenna_el_deg: float | None
    antenna_bearing_deg: float | None
    command_az_m_deg: float | None
    command_el_deg: float | None
    error_deg: float | None
    aos_s: float
    los_s: float
    progress: float                  # 0..1 through AOS..LOS
    commands: int
    note: str = ""


def _plausible_step(spec: RotatorSpec, before: tuple[float, float | None],
                    after: tuple[float, float | None], dt_s: float) -> bool:
    """True if a rotator at ``before`` can read ``after`` ``dt_s`` later: each axis moved at
    most its rate allows, plus the read-back's rounding."""
    slack_deg = 1.5 * spec.resolution_deg
    dt_s = max(dt_s, 0.0)
    if abs(after[0] - before[0]) > spec.az_rate_deg_s * dt_s + slack_deg:
        return False
    if after[1] is None or before[1] is None or not spec.has_elevation:
        return True
    return abs(after[1] - before[1]) <= spec.el_rate_deg_s * dt_s + slack_deg


# Plan modes whose path is the plan's own quantised commands (MountPath.exact_from_plan):
# a staircase, whose rate from one sample to the next jumps between 0 (a step held) and twice
# the mean. Near a keyhole's zenith the mean sits close to the follow threshold, so the loop
# would switch between following the plan and aiming on it every few seconds - and an aim
# taken on a held step lies behind the antenna (a reversal each time). There each sample's
# rate is the highest within this many seconds either side, and the plan's commands go out
# at the cycle nearest their planned time: the planner's prediction is the only one there.
STAIRCASE_MODES = ("keyhole", "unwind", "ahead")
STAIRCASE_RATE_WINDOW_S = 3.0


def _window_max(t_s: np.ndarray, values: np.ndarray, half_width_s: float) -> np.ndarray:
    """Per row of ``values``, the column-wise maximum over the rows within
    ``half_width_s`` of its time (``t_s`` ascending)."""
    lo = np.searchsorted(t_s, t_s - half_width_s, side="left")
    hi = np.searchsorted(t_s, t_s + half_width_s, side="right")
    return np.array([values[a:b].max(axis=0) for a, b in zip(lo, hi, strict=True)])


def pass_window(track: SkyTrack, station: Station) -> tuple[float, float]:
    """AOS and LOS (UTC POSIX s) of ``track`` against the station's horizon and mask."""
    up = track.el_deg >= station.horizon_at(track.az_deg)
    if not up.any():
        mid = float(track.t_s[int(np.argmax(track.el_deg))])
        return mid, mid
    idx = np.flatnonzero(up)
    return float(track.t_s[idx[0]]), float(track.t_s[idx[-1]])


class TrackCore:
    """The loop's decisions for one pass; no I/O, no clock.

    ``plan`` is a :class:`tracker.planner.MountPlan` (or anything with ``t_s``,
    ``cmd_az_deg``, ``cmd_el_deg``, ``mode``, ``preposition_t_s``, ``preposition``).
    ``sky(t_s) -> (az, el)``, if given, is where the target is at times outside ``track``
    (for the status while waiting for the pass).
    Call :meth:`observe` with each read-back, then :meth:`decide`; after a command went out,
    :meth:`commanded`. :meth:`resync` after a reconnect.
    """

    def __init__(self, plan, track: SkyTrack, spec: RotatorSpec, station: Station,
                 settings: StreamSettings | None = None,
                 sky: Callable[[float], tuple[float, float]] | None = None):
        self.plan = plan
        self.track = track
        self._track_from_s, self._track_to_s = float(track.t_s[0]), float(track.t_s[-1])
        # Where the target is outside the track's span (waiting for the pass): shown, not
        # planned with; without it the track's first or last point stands in.
        self.sky = sky
        self.spec = spec
        self.station = station
        self.settings = settings or StreamSettings(deadband_deg=spec.deadband_deg)
        # Asked every cycle and fixed for the pass.
        self._frame = spec.frame
        self._has_el = spec.has_elevation
        s = self.settings
        self._band_deg = max(s.deadband_deg - s.margin_deg, 0.5 * s.deadband_deg)
        self._lookahead_s = s.cycle_s + spec.start_delay_s
        # (read-back, its bearing, its mount_look) for the status
        self._look: tuple[tuple[float, float | None], float, MountLook | None] | None = None
        self.path = MountPath.exact_from_plan(plan, None, spec)
        # Where the path needs the motors to run most of the time (near the zenith), the
        # deadband saves no relay clicks - commands in the running direction start nothing -
        # and holding would build an azimuth lag that takes long to catch up. There the loop
        # follows the plan's own led commands, whose error the planner predicted.
        # Per-cycle look-ups go through lists (bisect, scalar lerp): cheaper than numpy
        # calls on one-element arrays.
        dt = np.gradient(self.path.t_s)
        self._path_t = self.path.t_s.tolist()
        path_el = self.path.el_deg if self.path.el_deg is not None else np.zeros_like(dt)
        rates = np.stack([np.abs(np.gradient(self.path.az_m_deg) / dt),
                          np.abs(np.gradient(path_el) / dt)], axis=1)
        self._staircase = str(getattr(plan, "mode", "normal")) in STAIRCASE_MODES
        if self._staircase:
            rates = _window_max(self.path.t_s, rates, STAIRCASE_RATE_WINDOW_S)
        self._rates = rates.tolist()
        # Where both ends of a sample interval are well below the follow thresholds, so is
        # every rate interpolated in it: :meth:`_fast` needs no interpolation there. Entry
        # j + 1 covers the interval starting at sample j (entry 0: before the first sample,
        # the last: after the last).
        f = self.settings.follow_fraction
        el_thr = f * spec.el_rate if spec.has_elevation else math.inf
        slow = ((rates[:, 0] < f * spec.az_rate_deg_s * (1.0 - 1e-9))
                & (rates[:, 1] < el_thr * (1.0 - 1e-9)))
        self._slow_from = [bool(slow[0]), *(slow[:-1] & slow[1:]).tolist(), bool(slow[-1])]
        plan_az = np.asarray(plan.cmd_az_deg, dtype=float)
        self._plan_az = plan_az.tolist()
        self._plan_el = np.asarray(getattr(plan, "cmd_el_deg", np.zeros_like(plan_az)),
                                   dtype=float).tolist()
        self._plan_t = np.asarray(plan.t_s, dtype=float).tolist()
        self.mode = str(getattr(plan, "mode", "normal"))
        self.aos_s, self.los_s = pass_window(track, station)
        self.track_from_s = max(self.path.start_s,
                                self.aos_s - 2 * self.settings.cycle_s - spec.start_delay_s)
        pre = getattr(plan, "preposition", None)
        if pre is None:
            pre = (float(self.path.az_m_deg[0]), float(path_el[0]))
        self.preposition_t_s = float(getattr(plan, "preposition_t_s", self.path.start_s))
        # The planner's mask-safe move sequences (elevation up, azimuth across, elevation
        # down); a plan without them gets one direct move.
        self.pre_moves = self._moves(getattr(plan, "preposition_moves", None),
                                     (self.preposition_t_s, pre[0], pre[1]))
        self.preposition_t_s = min(self.preposition_t_s, self.pre_moves[0][0])
        park_moves = getattr(plan, "park_moves", None)
        self.park_moves = self._moves(park_moves, (self.los_s, spec.park_az_deg,
                                                   spec.park_el_deg))
        self._move_i = 0
        self.motor: MotorModel | None = None       # belief of where the motors are/go
        self.phase = _WAIT
        self.last_command: Command | None = None
        self.commands = 0
        self.antenna: tuple[float, float | None] | None = None   # mechanical read-back
        self._antenna_t_s = -math.inf                            # when it was read
        self.untrusted = 0          # agreeing read-backs still needed after a contradiction
        self.note = ""
        self._watch = {"az": AxisWatch(), "el": AxisWatch()}
        self._w_az, self._w_el = self._watch["az"], self._watch["el"]   # (asked every cycle)
        self._phase_commanded: Phase | None = None
        # (phase, move index) of a pre-position/park sequence cut short by a reconnect or an
        # all-stop: it resumes at the move under way, not back at the first one (which would
        # turn the antenna back across the sky).
        self._resume: tuple[Phase, int] | None = None
        self._hold_until_s = -math.inf
        self._hold_level_deg = self.settings.deadband_deg
        # (from, until, level, az stamp, el stamp): needs_command is False all along (_quiet).
        self._quiet_span: tuple[float, float, float, int, int | None] | None = None
        self._park_sent_s: float | None = None
        self._last_wire_az: float | None = None
        # (wire azimuth, belief) -> its mechanical azimuth, of the last reading (_observe)
        self._mech_key: tuple[float, float | None] | None = None
        self._mech_az = 0.0
        self._wire_still_since_s = -math.inf
        self._az_command_t_s = -math.inf        # when the azimuth was last told a new target
        self._resend_due = False
        self._inconsistent_since_s: float | None = None
        # The whole-pass schedule (tracker.schedule), planned on the first settled cycle.
        self._schedule: PassSchedule | None = None
        self._schedule_i = 0
        self._schedule_tried = not (self.settings.planned_schedule and spec.has_elevation)
        # Where a schedule ended before a fast stretch it could not keep: after the stretch
        # the rest of the pass is planned again.
        self._replan_from_s: float | None = None

    # Read-back ---------------------------------------------------------------------------

    def observe(self, t_s: float, wire_az_deg: float, wire_el_deg: float | None) -> str:
        """Take one read-back; returns "ok", "controller_off" or "contradiction".

        Raises :class:`StallError` when a commanded axis has not moved although the motor
        model says it should have travelled ``stall_travel_deg`` by now, and
        :class:`ReadbackError` when no read-back could be trusted for
        ``inconsistent_give_up_s``.
        """
        seen = self._observe(t_s, wire_az_deg, wire_el_deg)
        if seen != "contradiction":
            self._inconsistent_since_s = None
            return seen
        if self._inconsistent_since_s is None:
            self._inconsistent_since_s = t_s
        lasted_s = t_s - self._inconsistent_since_s
        if lasted_s > self.settings.inconsistent_give_up_s:
            el = "" if wire_el_deg is None else f" el {wire_el_deg:.0f}"
            raise ReadbackError(
                f"controller read-back is inconsistent: for {lasted_s:.0f} s no read-back "
                f"agreed with the one before or with where the rotator can be after the "
                f"commands sent (last: az {wire_az_deg:.0f}{el}); the rotator was stopped. "
                f"Check the position sensors and their cable, and that no other program "
                f"talks to the controller")
        return seen

    # Read-back interpretation: the order of its checks is the behaviour (controller off,
    # early arrival, untrusted, contradiction), kept in one place to read in that order.
    def _observe(self, t_s: float, wire_az_deg: float, wire_el_deg: float | None) -> str:  # noqa: C901
        spec = self.spec
        self._resend_due = False      # decided afresh from this reading
        if wire_az_deg < 0 and (wire_el_deg is None or wire_el_deg < 0):
            # GS-232 reads AZ=-001 EL=-002 when the rotator's control box is off.
            self.note = "controller reports no position (control box off?) - waiting"
            self.resync()
            self.untrusted = self.settings.settle_readings
            return "controller_off"
        # The belief: the motor model, else the last read-back, else the reading's own scale.
        motor = self.motor
        contradiction_deg = self.settings.contradiction_deg
        # (the scalar position is a float already)
        expected_az = motor.az.position(t_s) if motor is not None else None
        belief = expected_az if expected_az is not None else (
            self.antenna[0] if self.antenna else None)
        # At rest the reading and the belief stay the same cycle after cycle: so does this.
        if (wire_az_deg, belief) == self._mech_key:
            m_az = self._mech_az
        else:
            m_az = self._frame.nearest_mech_of_wire(wire_az_deg, belief)
            self._mech_key, self._mech_az = (wire_az_deg, belief), m_az
        early = False
        if self._last_wire_az is None or abs(wire_az_deg - self._last_wire_az) >= 0.5:
            self._wire_still_since_s = t_s
        self._last_wire_az = wire_az_deg
        # Standing still while believed moving names an early arrival when the rotator was
        # seen moving since the command and then stopped; one never seen moving may just
        # start late (a 0 -> 360 turn still reads 0, which names 360 too), so it counts only
        # once the reading has not changed for longer than any start delay.
        still_s = t_s - self._wire_still_since_s
        still = still_s > 0.0 and (self._wire_still_since_s > self._az_command_t_s
                                   or still_s >= spec.start_delay_s + 1.5)
        if motor is not None and (
                abs(m_az - expected_az) > contradiction_deg
                or (still and motor.az.moving(t_s, expected_az))):
            # Far from the belief (or standing still while believed moving), but the reading
            # names the commanded target: it arrived sooner than believed (the start was
            # guessed on the wrong side of the overlap; the controller knew better). Take it,
            # instead of distrusting a good rotator.
            at_target = [m for m in spec.frame.mechs_of_wire(wire_az_deg)
                         if abs(m - motor.az.target_deg) < 0.5
                         and abs(m - m_az) > 180.0]
            if at_target:
                m_az, early = at_target[0], True
        el = None
        if self._has_el:
            el = float(wire_el_deg if wire_el_deg is not None else 0.0)
        prev, prev_t_s = self.antenna, self._antenna_t_s
        self.antenna, self._antenna_t_s = (m_az, el), t_s
        if self.untrusted:
            # After a contradiction or a dead controller: trust only read-backs that agree
            # with the one before: the same position, or one the rotator can have reached
            # from it since at its rates (it may still be on a long slew, for a minute or
            # more, and a moving rotator is not an inconsistent one).
            same = prev is not None and _plausible_step(spec, prev, self.antenna,
                                                         t_s - prev_t_s)
            self.untrusted = self.untrusted - 1 if same else self.settings.settle_readings
        if self.motor is None:
            self._sync_motor(t_s, moving=False)
            return "contradiction" if self.untrusted else "ok"
        if early:
            self.note = f"azimuth read-back {wire_az_deg:.0f} means arrived at {m_az:.0f}"
            self._sync_motor(t_s, moving=False)
            for w in self._watch.values():
                w.reset()
            expected_az = m_az
        off_az = abs(m_az - expected_az)
        off_el = 0.0 if el is None else abs(el - self.motor.el.position(t_s))
        if off_az > contradiction_deg or off_el > contradiction_deg:
            # Not where it can be if it obeyed us: someone turned it by hand, the controller
            # was recalibrated, or it folded its scale. Stop believing; wait for it to settle.
            el_said = "" if wire_el_deg is None else f" el {wire_el_deg:.0f}"
            self.note = (f"read-back az {wire_az_deg:.0f}{el_said} is "
                         f"{max(off_az, off_el):.0f} deg from where the rotator should be; "
                         f"re-syncing before the next move")
            self.untrusted = self.settings.settle_readings
            self.motor = None
            self._sync_motor(t_s, moving=False)
            for w in self._watch.values():
                w.reset()
            return "contradiction"
        if self.untrusted:
            return "contradiction"
        self._check_stall(t_s)
        # Keep the belief honest: read-back is integer degrees and a cycle late, so only
        # re-sync when the two clearly disagree.
        if off_az > 1.5 * spec.resolution_deg or off_el > 1.5 * spec.resolution_deg:
            self._sync_motor(t_s, moving=True)
        return "ok"

    def _sync_motor(self, t_s: float, moving: bool) -> None:
        az, el = self.antenna
        if self.motor is None:
            self.motor = MotorModel(self.spec, az_deg=az, el_deg=el, t_s=t_s)
            return
        self.motor.az = moving_axis(self.motor.az, az, self.motor.az.target_deg, t_s,
                                    moving and self.motor.az.moving(t_s))
        if self.motor.el is not None and el is not None:
            self.motor.el = moving_axis(self.motor.el, el, self.motor.el.target_deg, t_s,
                                        moving and self.motor.el.moving(t_s))

    def _check_stall(self, t_s: float) -> None:
        """Raise :class:`StallError` for an axis that stayed still although the commands
        sent since it last moved should have moved it, once the last chance had its time:
        one copy when the controller is known to have acted on a command (it may have been
        garbled into another valid one), else ``stall_resends`` copies or new commands.
        Until then ask for a copy (:attr:`_resend_due`)."""
        s = self.settings
        res = self.spec.resolution_deg
        w_az, w_el = self._w_az, self._w_el
        az, el = self.antenna
        stuck_az = w_az.check(t_s, az, res, s.stall_travel_deg)
        stuck_el = None if el is None else w_el.check(t_s, el, res, s.stall_travel_deg)
        if (stuck_az is None and stuck_el is None and not w_az.send_times
                and not w_el.send_times):
            # Most cycles: nothing to judge; a copy is due only if motion is overdue.
            # (an axis whose motion was just seen has none overdue: skip asking)
            self._resend_due = self.last_command is not None and (
                (w_az.ref_t_s != t_s and w_az.motion_overdue(t_s, res))
                or (el is not None and w_el.ref_t_s != t_s and w_el.motion_overdue(t_s, res)))
            return
        quota = 1 + s.stall_resends
        checked = [("azimuth", w_az, w_el, stuck_az)]
        if el is not None:
            checked.append(("elevation", w_el, w_az, stuck_el))
        overdue = []
        for name, watch, other, stuck_s in checked:
            if not watch.send_times:
                # Nothing sent since motion was last seen: no chance had, none to judge by;
                # a copy is due when a stall or overdue motion shows (most cycles: neither).
                if stuck_s is not None or watch.motion_overdue(t_s, res):
                    overdue.append(watch)
                continue
            # One line carries both axes: another axis starting on it shows that it arrived.
            others = other.ack_sends
            # Any of three ways shows the controller had its chance; the first one counts.
            done = watch.sends_had_their_chance(t_s, quota)
            can_copy = watch.sends < quota
            told_t = watch.told_at(others)
            if told_t is not None:
                # The controller acted on a command that asked this axis to move (the other
                # axis started on it, or this one ran and stopped short): one more send
                # first, in case line noise garbled this axis's field into another value.
                later = watch.sends_after(told_t)
                done = done or (bool(later) and watch.had_time_since(t_s, later[0]))
                can_copy = can_copy and not later
            if stuck_s is not None and done:
                raise stall_error(f"{name} did not move: {watch.observation(t_s).text()}")
            if can_copy and (stuck_s is not None or watch.motion_overdue(t_s, res)):
                overdue.append(watch)
        self._resend_due = self.last_command is not None and bool(overdue)

    # Decisions -------------------------------------------------------------------------------

    def _phase_at(self, t_s: float) -> Phase:
        if self.phase is _DONE:
            return _DONE
        if t_s > self.los_s:
            return _PARK
        if t_s >= self.track_from_s:
            return _TRACK
        if t_s >= self.preposition_t_s:
            return _PREPOSITION
        return _WAIT

    def decide(self, t_s: float) -> Command | None:
        """What to send now (None: nothing). Call after :meth:`observe` each cycle."""
        cmd = self._decide(t_s)
        if cmd is None and self._resend_due and self.motor is not None and not self.untrusted \
                and self.phase is not _WAIT and self.phase is not _DONE:
            # The last command moved nothing so far: it may have been lost on the line. (A
            # new command, when one is due, is a fresh chance in itself.)
            last = self.last_command
            return replace(last, resend=last.resend + 1)
        return cmd

    # The per-cycle decision by phase; the phases share the cycle's state.
    def _decide(self, t_s: float) -> Command | None:  # noqa: C901
        phase = self.phase
        # Most cycles stay in TRACK: _phase_at's answer then, without the call.
        if phase is not _TRACK or not self.track_from_s <= t_s <= self.los_s:
            phase = self._phase_at(t_s)
            if phase is not self.phase:
                self.phase = phase
        if self.motor is None or self.untrusted:
            return None       # no trusted position: never a blind move
        if not self._schedule_tried and (phase is _WAIT or (
                phase is _PREPOSITION and self._move_i == 0)):
            self._plan_ahead(t_s)
        if phase is _WAIT or phase is _DONE:
            return None
        if phase is _PREPOSITION:
            cmd = self._next_move(t_s, self.pre_moves, "preposition")
            if cmd is not None and self._move_i == len(self.pre_moves) - 1:
                cmd = self._lead_in(t_s, cmd)
            return cmd
        if phase is _PARK:
            if not self.settings.park_after_pass:
                self.phase = _DONE
                return None
            cmd = self._next_move(t_s, self.park_moves, "park")
            if cmd is not None:
                return cmd
            # Arrived means the read-back says so, not only the belief: the final all-stop
            # must not cut the park short.
            last = self.last_command
            arrived = (self._move_i >= len(self.park_moves) and not self.motor.moving(t_s)
                       and last is not None and self.antenna is not None
                       and abs(self.antenna[0] - last.az_m_deg) <= self.spec.resolution_deg
                       and (last.el_deg is None or self.antenna[1] is None
                            or abs(self.antenna[1] - last.el_deg) <= self.spec.resolution_deg))
            timed_out = (self._park_sent_s is not None
                         and t_s - self._park_sent_s > self.settings.park_timeout_s)
            if arrived or timed_out:
                self.phase = _DONE
            return None
        # TRACK
        s = self.settings
        band = self._band_deg
        level = band if t_s >= self._hold_until_s else max(band, self._hold_level_deg)
        # Move before the error reaches the deadband, but no earlier than needed: every second
        # of early warning moves the next aim point back by the path's travel in that time.
        # Once a motor runs it outruns the target (faster paths are followed below), so only
        # the wait until it starts has to be foreseen: one cycle and the start delay.
        lookahead = self._lookahead_s
        # After the whole pre-position (which already leads into the pass) the antenna
        # may hold where it is, as within the pass.
        settled = self._phase_commanded is _TRACK or (
            self._phase_commanded is _PREPOSITION and self._move_i >= len(self.pre_moves))
        if settled and (self._schedule is not None or not self._schedule_tried
                        or self._replan_from_s is not None):
            # The whole-pass schedule while it lasts, fast stretches it keeps included.
            planned = self._planned(t_s, lookahead)
            if planned is not _AIM:
                return planned
        if self._fast(t_s, lookahead):
            i = (self._plan_index_near(t_s) if self._staircase
                 else min(bisect_left(self._plan_t, t_s), len(self._plan_t) - 1))
            el = self._plan_el[i] if self.spec.has_elevation else None
            cmd = self._safe(self._plan_az[i], el, "track")
            self._hold_until_s = -math.inf
            motor = self.motor
            if self._staircase and self._phase_commanded is _TRACK and abs(
                    motor.az.target_deg - cmd.az_m_deg) < 1e-9 and (
                    cmd.el_deg is None or motor.el is None
                    or abs(motor.el.target_deg - cmd.el_deg) < 1e-9):
                # The step nearest now (or the limit a guard holds it to) is what the motors
                # are already sent to, and the antenna may have reached it and stopped:
                # sending it again would only restart the motor. After an all-stop or a
                # resync the belief's target is where the antenna stands, so the step goes
                # out again; a command that did not move it is the stall watch's to re-send.
                return None
        else:
            if settled and self._quiet(t_s, level, lookahead):
                return None
            aim = choose_aim(self.path, self.motor.az, self.motor.el, t_s, band,
                             step_s=s.aim_step_s)
            cmd = self._safe(aim.az_m_deg, aim.el_deg, "track", aim)
        last = self.last_command
        if self._phase_commanded is _TRACK and last is not None and self.motor.moving(
                t_s):
            # Already on its way (or one step off it): a repeat would only cost relay clicks.
            res = self.spec.resolution_deg
            same_az = abs(cmd.az_m_deg - last.az_m_deg) <= res + 1e-9
            same_el = cmd.el_deg is None or last.el_deg is None or abs(
                cmd.el_deg - last.el_deg) <= res + 1e-9
            if same_az and same_el and cmd.aim is not None:
                return None
            if cmd.aim is None and abs(cmd.az_m_deg - last.az_m_deg) < 1e-9 and (
                    cmd.el_deg is None or abs(cmd.el_deg - last.el_deg) < 1e-9):
                return None
        return cmd

    def _quiet(self, t_s: float, level_deg: float, lookahead_s: float) -> bool:
        """``not needs_command(...)``: the antenna, left alone, stays within ``level_deg``
        for the look-ahead. Proved by a bound for a while ahead (:func:`quiet_until_s`), the
        answer is kept until then, as long as the belief of the motors does not change (their
        :attr:`~tracker.mount.AxisMotor.stamp`)."""
        motor = self.motor
        assert motor is not None, "only asked with a belief"
        az_stamp, el_stamp = motor.az.stamp, None if motor.el is None else motor.el.stamp
        q = self._quiet_span
        if (q is not None and q[0] <= t_s <= q[1] and level_deg >= q[2] and az_stamp == q[3]
                and el_stamp == q[4]):
            return True
        until = quiet_until_s(self.path, motor.az, motor.el, t_s, level_deg, lookahead_s,
                              first_s=self.settings.cycle_s)
        if until is None:
            if needs_command(self.path, motor.az, motor.el, t_s, level_deg, lookahead_s):
                return False
            until = t_s
        self._quiet_span = (t_s, until, level_deg, az_stamp, el_stamp)
        return True

    def _plan_index_near(self, t_s: float) -> int:
        """Index of the plan's command whose time is nearest ``t_s`` (the later one on a
        tie): each goes out within half a plan step of the time the planner gave it, early
        or late, the timing its prediction assumes."""
        pt = self._plan_t
        j = bisect_left(pt, t_s)
        if j >= len(pt):
            return len(pt) - 1
        if j > 0 and t_s - pt[j - 1] < pt[j] - t_s:
            return j - 1
        return j

    def _planned(self, t_s: float, lookahead_s: float) -> Command | object | None:
        """The whole-pass schedule's move due now, None to hold, or ``_AIM`` when the aim
        policy decides: no schedule (not wanted, none keeps the band, a motor was moving
        when it would have been planned), or the schedule was dropped because the belief
        (the read-back's) left it, a move came late or a guard changed one. Planned ahead,
        before the pre-position (:meth:`_plan_ahead`); where that was too late, or after a
        fast stretch the schedule stopped short of, on the first settled cycle with both
        motors at rest. Once dropped the aim policy decides the rest of the pass."""
        if self._schedule is None:
            again = self._replan_from_s is not None and t_s >= self._replan_from_s and \
                not self._fast(t_s, lookahead_s)
            if (self._schedule_tried and not again) or self.motor.moving(t_s):
                return _AIM
            self._schedule_tried, self._replan_from_s = True, None
            self._schedule = self._plan_schedule(t_s, lookahead_s)
            self._schedule_i = 0
            if self._schedule is None:
                return _AIM
        sch = self._schedule
        if t_s < sch.sample_t_s[0] - 1e-6:
            return None     # planned ahead: the pre-position is on its way to the start
        res = self.spec.resolution_deg
        az, el = self.motor.position(t_s)
        want_az, want_el = sch.expected(t_s)
        # A schedule cut before a fast stretch keeps the band only up to its end: the aim
        # policy takes over a lookahead before it, in time to move before the target leaves.
        end_s = sch.end_s if sch.end_s >= self.los_s - self.settings.cycle_s else \
            sch.end_s - lookahead_s
        if t_s > end_s or abs(az - want_az) > 1.5 * res or abs(el - want_el) > 1.5 * res:
            self._schedule = None
            return _AIM
        # A move goes out on the cycle nearest its planned instant (a real clock's cycles
        # drift off the planned ones): up to half a cycle early or late.
        half = 0.5 * self.settings.cycle_s
        i = self._schedule_i
        if i >= len(sch.t_s) or sch.t_s[i] > t_s + half + 1e-6:
            return None
        self._schedule_i = i + 1
        cmd = self._safe(sch.az_m_deg[i], sch.el_deg[i], "track")
        if t_s - sch.t_s[i] > half + 1e-6 or cmd.clamped:
            self._schedule = None
            return _AIM
        return cmd

    def _plan_ahead(self, t_s: float) -> None:
        """Before the pre-position: the whole-pass schedule from the last cycle before
        tracking starts, free to begin anywhere (the pre-position's last move goes to its
        start, :meth:`_lead_in`). Planned this early, its CPU time is spent while nothing
        waits on it."""
        self._schedule_tried = True
        cycle = self.settings.cycle_s
        k = math.floor((self.track_from_s - t_s) / cycle + 1e-9)
        if k < 1:
            self._schedule_tried = False      # too late: planned on the first settled cycle
            return
        self._schedule = self._plan_schedule(t_s + k * cycle, self._lookahead_s,
                                             free_start=True)
        self._schedule_i = 0
        if self._schedule is not None and self.motor is not None:
            # The whole pre-position goes to the schedule's start, by the mask-safe sequence
            # the planner gives any move: a sequence aimed at the plan's start would turn an
            # axis there first and then on to the schedule's, a start for nothing.
            sch = self._schedule
            az, el = self.motor.position(t_s)
            start = (float(sch.az_pos_deg[0]), float(sch.el_pos_deg[0]))
            moves, _dur_s = safe_moves(self.spec, self.station, (az, el or 0.0), start,
                                       self.pre_moves[0][0])
            self.pre_moves = self._moves(moves, (self.pre_moves[0][0], *start))
            self._move_i, self._resume = 0, None

    def _plan_schedule(self, t_s: float, lookahead_s: float, free_start: bool = False
                       ) -> PassSchedule | None:
        """:func:`~tracker.schedule.plan_schedule` from now to LOS; where no schedule keeps
        the band through a stretch where the path turns fast (near the zenith), up to
        :data:`SCHEDULE_HANDOFF_S` before it: the loop follows the plan's own commands there,
        and the aim policy leads into them as it does without a schedule."""
        if self.motor is None or self.motor.el is None:
            return None
        cycle = self.settings.cycle_s
        band = max(self.settings.deadband_deg - SCHEDULE_MARGIN_DEG, self._band_deg)
        end_s = self.los_s
        t = t_s
        while t <= end_s:
            if self._fast(t, lookahead_s):
                end_s = t - SCHEDULE_HANDOFF_S
                break
            t += cycle
        from_s = max(self.track_from_s, t_s)
        if end_s < self.los_s:
            whole = plan_schedule(self.path, self.motor.az, self.motor.el, t_s, self.los_s,
                                  band, cycle, from_s=from_s, free_start=free_start)
            if whole is not None:
                return whole
            self._replan_from_s = t
        return plan_schedule(self.path, self.motor.az, self.motor.el, t_s, end_s, band, cycle,
                             from_s=from_s, free_start=free_start)

    def _lead_in(self, t_s: float, last: Command, horizon_s: float = 120.0) -> Command:
        """The last pre-position move, aimed ahead on the path: resting there the antenna
        lets the target drift through the whole deadband from the start of tracking, where
        resting on the AOS point it would need one small move just before AOS, a motor start
        per axis for nothing. Kept as planned when no point ahead holds the deadband from the
        start of tracking or the direct move to it would dip below the mask. With a schedule
        planned ahead (:meth:`_plan_ahead`), the move goes to its start instead."""
        if self._schedule is not None:
            sch = self._schedule
            start = self._safe(float(sch.az_pos_deg[0]), float(sch.el_pos_deg[0]),
                               "preposition")
            if not start.clamped and move_clears_mask(
                    self.spec, self.station, self.motor.position(t_s),
                    (start.az_m_deg, start.el_deg)):
                return start
            # Not there: planned again from where the antenna comes to rest.
            self._schedule, self._schedule_tried = None, False
        t_a = self.track_from_s
        ts = np.arange(t_a, min(t_a + horizon_s, self.path.end_s) + 1e-9,
                       self.settings.aim_step_s)
        if len(ts) < 2:
            return last
        cand_az, cand_el = self.path.mount_at(ts)
        q_az = np.array([self.motor.az.quantise(a) for a in cand_az])
        q_el = (np.array([self.motor.el.quantise(e) for e in cand_el])
                if self.motor.el is not None and last.el_deg is not None and cand_el is not None
                else np.zeros_like(q_az))
        # Neighbouring path points quantise to the same few positions: each distinct one once.
        _u, first, inv = np.unique(q_az + 1j * q_el, return_index=True, return_inverse=True)
        err = angle_between_deg(pointing_enu(q_az[first], q_el[first],
                                             self.path.stop_bearing_deg)[:, None],
                                self.path.target_enu(ts)[None, :])    # (distinct position, t)
        off = err > self._band_deg
        # Held from the start of tracking: a candidate counts until the error first leaves
        # the deadband, and only if it is inside at the start.
        hold = np.where(off.any(axis=1), np.argmax(off, axis=1), len(ts))[inv.ravel()]
        if not (hold > 0).any():
            return last
        # Hold per motor start, as within the pass (an axis already on target costs none).
        starts = (np.abs(q_az - self.motor.az.target_deg) > 1e-9).astype(float)
        if self.motor.el is not None and last.el_deg is not None:
            starts += np.abs(q_el - self.motor.el.target_deg) > 1e-9
        k = int(np.argmax(np.where(hold > 0, hold / (starts + COMMAND_COST_STARTS), -1.0)))
        lead = self._safe(float(q_az[k]), None if last.el_deg is None else float(q_el[k]),
                          "preposition")
        if lead.clamped or not move_clears_mask(self.spec, self.station,
                                                self.motor.position(t_s),
                                                (lead.az_m_deg, lead.el_deg)):
            return last
        return lead

    def _fast(self, t_s: float, lookahead_s: float) -> bool:
        """True where the path runs the az or el motor more than ``follow_fraction`` of
        the time (near the zenith, keyhole sweeps)."""
        path_t, slow_from = self._path_t, self._slow_from
        if (slow_from[bisect_right(path_t, t_s)]
                and slow_from[bisect_right(path_t, t_s + lookahead_s)]):
            return False
        f = self.settings.follow_fraction
        az0, el0 = interp1_rows(t_s, self._path_t, self._rates)
        az1, el1 = interp1_rows(t_s + lookahead_s, self._path_t, self._rates)
        if max(az0, az1) > f * self.spec.az_rate_deg_s:
            return True
        if self.spec.has_elevation:
            return max(el0, el1) > f * self.spec.el_rate_deg_s
        return False

    def _moves(self, moves, fallback) -> list[tuple[float, float, float | None]]:
        out = [(float(m.t_s), float(m.az_deg), float(m.el_deg)) for m in (moves or ())]
        if not out:
            out = [(float(fallback[0]), float(fallback[1]), float(fallback[2]))]
        if not self.spec.has_elevation:
            out = [(t, a, None) for t, a, _e in out]
        return out

    def _next_move(self, t_s: float, moves, reason: str) -> Command | None:
        """The next of a move sequence: each waits for the previous one to arrive."""
        if self._phase_commanded is not self.phase:
            r = self._resume
            self._move_i = r[1] if r is not None and r[0] is self.phase else 0
        if self._move_i >= len(moves):
            return None
        if self._move_i > 0 and self.motor.moving(t_s):
            return None
        if self._move_i == 0 and t_s < moves[0][0] and reason != "park":
            return None
        _t, az, el = moves[self._move_i]
        return self._safe(az, el, reason)

    def _safe(self, az_m: float, el: float | None, reason: str, aim: Aim | None = None
              ) -> Command:
        az_c, el_c, why = safe_target(self.spec, self.station, az_m, el)
        return Command(az_c, el_c, reason, aim, why)

    def commanded(self, t_s: float, cmd: Command) -> None:
        """Record that ``cmd`` was sent at ``t_s``."""
        if self.motor is None:
            return
        if cmd.resend:
            # A copy of the last command: the belief and the plan's progress stay as they
            # are; only the stall watch learns of the extra chance.
            for w in self._watch.values():
                w.resent(t_s)
            self._resend_due = False
            self.last_command = cmd
            self.commands += 1
            return
        if abs(cmd.az_m_deg - self.motor.az.target_deg) > 1e-9:
            self._az_command_t_s = t_s
        self.motor.command(cmd.az_m_deg, cmd.el_deg, t_s)
        az, el = self.antenna
        self._watch["az"].start(self.motor.az, t_s, az)
        if self.motor.el is not None and el is not None:
            self._watch["el"].start(self.motor.el, t_s, el)
        self.last_command = cmd
        self.commands += 1
        self._resend_due = False
        phase = _PHASE_OF_REASON.get(cmd.reason, self.phase)
        if cmd.reason in ("preposition", "park"):
            self._move_i += 1     # _next_move set it to the index of this move
        self._phase_commanded = phase
        self._resume = None
        if cmd.reason == "park":
            self._park_sent_s = t_s
        if cmd.aim is not None:
            # The raised level only covers the slew: past the arrival the look-ahead must
            # see the next exit from the deadband early enough to move before it.
            self._hold_until_s = min(t_s + cmd.aim.hold_s,
                                     cmd.aim.arrival_s + self.settings.cycle_s)
            self._hold_level_deg = cmd.aim.peak_error_deg + 0.05
        self.note = ""

    def resync(self) -> None:
        """After a reconnect: forget the belief; the next read-back re-seeds it and the
        current phase's move is sent again from the real position."""
        self.motor = None
        self._interrupt()
        for w in self._watch.values():
            w.reset()

    def _interrupt(self) -> None:
        """The commanded motion was cut (reconnect, all-stop): the current phase's move is
        sent again. Called repeatedly while the port is gone: only the first call records."""
        if self._schedule is not None and self.phase in (_WAIT, _PREPOSITION):
            self._schedule_tried = False      # not begun: planned again from where it stands
        self._schedule = None     # the motion it planned from was cut: the aim policy goes on
        if self._phase_commanded is not None:
            seq = self._phase_commanded in (_PREPOSITION, _PARK)
            self._resume = (self._phase_commanded, max(self._move_i - 1, 0)) if seq else None
        self._phase_commanded = None

    def stopped(self, t_s: float) -> None:
        """The rotator was told to stop (all-stop)."""
        if self.motor is not None:
            self.motor.stop(t_s)
        self._interrupt()

    # Reporting ---------------------------------------------------------------------------

    def status(self, t_s: float) -> Status:
        # Once a cycle: floats throughout (the track's span and the scalar paths).
        if self.sky is not None and not (self._track_from_s <= t_s <= self._track_to_s):
            taz, tel = self.sky(t_s)
            taz, tel = float(taz), float(tel)
        else:
            taz, tel = self.track.direction_at(float(t_s))    # floats on a float time
        ant = self.antenna
        err = bearing = None
        if ant is not None:
            el = ant[1] if ant[1] is not None else 0.0
            # The read-back changes far less often than the cycles come: its bearing and
            # boresight are kept while it stays (on floats, pointing_error_deg's own path).
            look = self._look
            if look is None or look[0] != ant:
                fl = isinstance(ant[0], float) and isinstance(el, float)
                look = self._look = (ant, float(self.spec.bearing_of(ant[0])),
                                     mount_look(self.spec, ant[0], el) if fl else None)
            bearing = look[1]
            # an azimuth-only beam's elevation is set by hand: only azimuth is ours to get
            # right, as in the planner's prediction
            if self.phase is not _PARK and self.phase is not _DONE:
                # after LOS the antenna leaves the target on purpose: no pointing error
                err = (look_error_deg(look[2], taz, tel) if look[2] is not None else
                       float(pointing_error_deg(self.spec, ant[0], el, (taz, tel))))
        aos_s, los_s = self.aos_s, self.los_s
        span = los_s - aos_s
        # min(max(x, 0), 1) and max(span, 1e-9), without the calls
        progress = (t_s - aos_s) / (1e-9 if 1e-9 > span else span)
        progress = 0.0 if progress < 0.0 else 1.0 if progress > 1.0 else progress
        cmd = self.last_command
        return Status(t_s, self.phase, self.mode, taz, tel,
                      None if ant is None else ant[0], None if ant is None else ant[1],
                      bearing, None if cmd is None else cmd.az_m_deg,
                      None if cmd is None else cmd.el_deg, err, aos_s, los_s, progress,
                      self.commands, self.note)


def safe_target(spec: RotatorSpec, station: Station, az_m_deg: float, el_deg: float | None
                ) -> tuple[float, float | None, str]:
    """Clamp a command to the rotator's limits and keep the boresight above the horizon
    mask; returns ``(az_m, el, why)`` with ``why`` empty when nothing changed. The last
    guard before any byte goes out, whatever the plan says."""
    why = []
    az = min(max(float(az_m_deg), 0.0), spec.az_span_deg)
    if az != az_m_deg:
        why.append(f"azimuth {az_m_deg:.1f} outside 0..{spec.az_span_deg:g}")
    az_top = spec.frame.top_command_deg(spec.resolution_deg)
    if az > az_top + 1e-9:
        why.append(f"azimuth {az:.1f} is the stop's bearing, which this controller takes as "
                   f"the CCW end; {az_top:g} instead")
        az = az_top
    if el_deg is None or not spec.has_elevation:
        return az, None, "; ".join(why)
    el = min(max(float(el_deg), spec.el_min_deg), spec.el_max_deg)
    if el != el_deg:
        why.append(f"elevation {el_deg:.1f} outside {spec.el_min_deg:g}..{spec.el_max_deg:g}")
    raised = float(raise_to_mask(spec, station, az, el))
    if raised != el:
        look_bearing, _look_el = boresight_look(spec, az, el)
        floor = float(station.horizon_at(look_bearing))
        el = min(max(raised, spec.el_min_deg), spec.el_max_deg)
        why.append(f"raised above the horizon mask ({floor:.1f} deg at "
                   f"{float(look_bearing):.0f})")
    return az, el, "; ".join(why)


# I/O loop ----------------------------------------------------------------------------------


EventSink = Callable[..., None]


def _null_sink(kind: str, **data) -> None:
    return None


def close_quietly(driver: object | None) -> None:
    """Close a driver whose port may already be gone (unplugged, reset): nothing is left to
    release then, and the error that lost it is reported elsewhere."""
    if driver is None:
        return
    try:
        driver.close()  # type: ignore[attr-defined]
    except (TrackerError, OSError):
        pass


@dataclass
class Link:
    """The driver plus how to get a new one when the port vanishes."""

    connect: Callable[[], object]
    spec: RotatorSpec
    driver: object | None = None
    events: EventSink = _null_sink

    def ensure(self):
        if self.driver is None:
            self.driver = self.connect()
            self.events("state", state="connected")
        return self.driver

    def drop(self) -> None:
        drv, self.driver = self.driver, None
        close_quietly(drv)

    def position(self) -> tuple[float, float | None]:
        reply = self.ensure().position()
        self.events("reply", az=reply[0], el=reply[1])
        return reply

    def goto(self, cmd: Command) -> None:
        wire_az = self.spec.frame.wire_of(cmd.az_m_deg)
        self.ensure().goto(wire_az, cmd.el_deg)
        self.events("command", cmd="goto", az=wire_az, el=cmd.el_deg, reason=cmd.reason,
                    az_m=cmd.az_m_deg, bearing=round(float(self.spec.bearing_of(cmd.az_m_deg)),
                                                     3),
                    clamped=cmd.clamped or None, resend=cmd.resend or None)

    def stop(self) -> bool:
        """All-stop; True if it reached the controller."""
        if self.driver is None:
            try:
                self.ensure()
            except (TrackerError, OSError):
                self.events("state", state="stop_failed", reason="port unavailable")
                return False
        try:
            self.driver.stop()
            self.events("command", cmd="stop")
            return True
        except (TrackerError, OSError) as e:
            self.events("state", state="stop_failed", reason=str(e))
            return False


@dataclass
class PassResult:
    commands: int
    reconnects: int
    max_error_deg: float
    errors_deg: list[float] = field(default_factory=list)
    final_position: tuple[float, float | None] | None = None
    completed: bool = True
    error_t_s: list[float] = field(default_factory=list)   # when each of errors_deg was seen
    cause: str = ""          # why the maximum error is large, if it is ("" otherwise)
    joined_late_s: float = 0.0   # started this long after AOS (0: from the pre-position)
    acquired_at: int = 0     # errors_deg before this index are the slew to catch the target

    def count_from_acquisition(self, joined_late_s: float, deadband_deg: float) -> None:
        """A pass joined under way: the slew to catch the target is not the tracking's
        error, so :attr:`max_error_deg` counts from the first reading on target."""
        if joined_late_s <= 0.0:
            return
        self.joined_late_s = joined_late_s
        self.acquired_at = acquisition_index(self.errors_deg, deadband_deg)
        tail = self.errors_deg[self.acquired_at:]
        self.max_error_deg = max(tail) if tail else float("nan")

    def joined_note(self) -> str:
        """``joined 300 s after AOS; on target 38 s later, error counted from then``."""
        if self.joined_late_s <= 0.0:
            return ""
        head = f"joined {self.joined_late_s:.0f} s after AOS"
        if self.acquired_at >= len(self.errors_deg):
            return f"{head}; never on target"
        if len(self.error_t_s) != len(self.errors_deg):     # readings without their times
            return f"{head}; error counted from the first reading on target"
        caught_s = self.error_t_s[self.acquired_at] - self.error_t_s[0]
        return f"{head}; on target {caught_s:.0f} s later, error counted from then"


def acquisition_index(errors_deg: Sequence[float], deadband_deg: float) -> int:
    """Index of the first error within ``deadband_deg`` + 1 deg (the length when none is):
    where a pass joined under way has caught its target."""
    on_deg = deadband_deg + 1.0
    return next((i for i, e in enumerate(errors_deg) if e <= on_deg), len(errors_deg))


# The streaming loop with its recovery paths (timeouts, garbled replies,
# reconnects, stop); they share the loop's counters and the all-stop on every exit.
def run_pass(core: TrackCore, link: Link, clock: Clock, on_status: Callable[[Status], None]  # noqa: C901
             = lambda s: None, events: EventSink = _null_sink,
             should_stop: Callable[[], bool] = lambda: False) -> PassResult:
    """Run one pass to the end (DONE) on ``clock``; all-stop on every exit. Raises
    :class:`StallError` or :class:`ReadbackError` (after stopping) and re-raises anything
    else after stopping, KeyboardInterrupt included."""
    s = core.settings
    link.events = events
    reconnects = 0
    timeouts = garbled = 0
    backoff_s = s.reconnect_initial_s
    lost_since: float | None = None
    errors: list[float] = []
    error_t_s: list[float] = []
    last_state = None
    ok = False
    try:
        next_t = clock.timestamp()
        while True:
            t = clock.timestamp()
            try:
                az, el = link.position()
                timeouts = garbled = 0
                if lost_since is not None:
                    events("state", state="reconnected",
                           note=f"port back after {t - lost_since:.1f} s; resuming the plan")
                    lost_since = None
                    backoff_s = s.reconnect_initial_s
                    core.resync()
                t = clock.timestamp()
                seen = core.observe(t, az, el)
                if seen != "ok" and seen != last_state:
                    events("state", state=seen, note=core.note)
                    if link.driver is not None:
                        link.stop()   # no motion while we do not know where it is
                        core.stopped(t)
                last_state = seen
                prev_phase = core.phase
                cmd = core.decide(t)
                if core.phase is not prev_phase:
                    events("state", state="phase", phase=core.phase.value)
                if cmd is not None:
                    link.goto(cmd)
                    core.commanded(clock.timestamp(), cmd)
            except StallError:
                raise
            except (PortLostError, RotatorTimeout, ProtocolError, RotatorIOError) as e:
                if isinstance(e, (RotatorTimeout, ProtocolError)) and not isinstance(
                        e, PortLostError):
                    if isinstance(e, ProtocolError):
                        garbled += 1
                    else:
                        timeouts += 1
                    events("state", state="no_reply", note=str(e), count=timeouts + garbled)
                    if timeouts < s.timeouts_before_lost and garbled < s.garbled_before_lost:
                        clock.sleep(s.cycle_s)
                        continue
                if lost_since is None:
                    lost_since = t
                    events("state", state="port_lost", note=str(e))
                link.drop()
                core.resync()
                if should_stop():
                    break          # asked to stop while the port is gone: do not wait for it
                if s.reconnect_give_up_s is not None and t - lost_since > s.reconnect_give_up_s:
                    raise PortLostError(f"port gone for {t - lost_since:.0f} s; giving up. "
                                        f"Last error: {e}") from e
                if t > core.los_s + s.park_timeout_s:
                    raise PortLostError(f"port lost and the pass is over: {e}") from e
                events("state", state="reconnecting", wait_s=backoff_s)
                clock.sleep(backoff_s)
                backoff_s = min(backoff_s * 2.0, s.reconnect_max_s)
                try:
                    link.ensure()
                    reconnects += 1
                except (TrackerError, OSError) as e2:
                    events("state", state="reconnect_failed", note=str(e2))
                continue
            st = core.status(t)
            if st.error_deg is not None and core.aos_s <= t <= core.los_s:
                errors.append(st.error_deg)
                error_t_s.append(t)
            on_status(st)
            if core.phase is _DONE:
                ok = True
                break
            if should_stop():
                break
            next_t += s.cycle_s
            wait = next_t - clock.timestamp()
            if wait < -s.cycle_s:
                next_t = clock.timestamp()   # fell behind (slow port): do not burst
            clock.sleep(max(wait, 0.0))
    except StallError as e:
        events("state", state="stall", note=str(e))
        raise
    except ReadbackError as e:
        events("state", state="readback_inconsistent", note=str(e))
        raise
    finally:
        # Every way out sends all-stop: Ctrl-C, SIGTERM (raised as KeyboardInterrupt), any
        # exception, a stop request, and the normal end too (parked by now, or staying where
        # the pass ended): the antenna must never keep turning on its own.
        link.stop()
        events("state", state="stopped" if not ok else "finished")
    return PassResult(commands=core.commands, reconnects=reconnects,
                      max_error_deg=max(errors) if errors else float("nan"),
                      errors_deg=errors, final_position=core.antenna, completed=ok,
                      error_t_s=error_t_s)
