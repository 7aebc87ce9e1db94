"""Stall detection: is a commanded axis turning as THE motor model says it must?

One module for both ways the tracker drives a rotator:

* :class:`AxisWatch` — live tracking (:mod:`tracker.stream`), one command at a time. It keeps
  where the axis was when motion was last seen and how far the commands since then should have
  moved it. Before an axis is judged stalled the live loop re-sends the command
  (:meth:`AxisWatch.motion_overdue`, ``StreamSettings.stall_resends``): a command lost to line
  noise produces no motion either, and a re-send costs nothing when the controller did get it
  (the relay is already closed in that direction).
* :class:`TableWatch` — step tables running on the controller (:mod:`tracker.upload`), judged
  from the recent read-backs against the table's points at their (late-shifted) times. The
  table runs on the box, so there is nothing to re-send: a suspected stall is read twice.

Both judge against :func:`tracker.mount.drive_axis` / :class:`tracker.mount.AxisMotor`,
never call a command that asks for no travel (or one the read-back shows reached) a stall, and
report with :func:`stall_error`: what was observed, and what may cause it, without claiming
which.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracker.errors import StallError
from tracker.mount import AxisMotor, RotatorSpec, drive_axis
from tracker.steptable import StepTable

# Read-backs are whole degrees: less progress than this is no motion.
STILL_DEG = 0.5


def stall_error(observed: str) -> StallError:
    """The one way a stall is reported: what was seen (``observed``), that the rotator was
    stopped, and the possible causes - a stall is inferred from read-backs, so the hardware
    may well be fine."""
    return StallError(f"{observed}; the rotator was stopped. Possible causes: a jammed motor "
                      f"or brake, a loose cable, a control box that ignores commands. Check "
                      f"them, then restart")


# Live tracking ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Observation:
    """What a stalled axis showed, for the message."""

    position_deg: float
    still_s: float
    commands: int
    target_deg: float

    def text(self) -> str:
        n = self.commands
        return (f"it stayed at {self.position_deg:.0f} deg for {self.still_s:.1f} s after "
                f"{n} command{'s' if n != 1 else ''} to {self.target_deg:.0f} deg")


class AxisWatch:
    """Stall bookkeeping for one axis under live control: where it was when motion was last
    seen, and how far the commands since then should have moved it (small tracking steps add
    up, so a jam is caught even when every single step is too small to judge)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.ref_t_s: float | None = None
        self.ref_pos_deg = 0.0
        self.expect: AxisMotor | None = None
        self.seg_t_s = 0.0
        self._seg_pos_deg = 0.0      # the expectation's position at seg_t_s (asked every cycle)
        self.carried_deg = 0.0
        self.still_since_s: float | None = None   # first read-back showing no motion
        # Commands (copies included) sent since motion was last seen, whether each asked
        # this axis to move, and which were copies of the same command.
        self.send_times: list[float] = []
        self.asked: list[bool] = []
        self.copy_times: list[float] = []
        self._told_t_s: float | None = None
        # Sends one of which the controller acted on: the axis stood still when the first
        # went out and moved after. Another axis still since then got that command too.
        self.ack_sends: tuple[float, ...] = ()
        self._series_at_rest = False
        # The motion last seen was the controller acting on a command sent at rest (not a
        # motor still running on an older one while a newer command may have been lost).
        self.acted_on = False

    def _segment_deg(self, t_s: float) -> float:
        if self.expect is None or t_s == self.seg_t_s:   # none yet since the segment began
            return 0.0
        return abs(self.expect.position(float(t_s)) - self._seg_pos_deg)

    def _new_segment(self, t_s: float) -> None:
        """The expectation changed at ``t_s``: travel counts from its position then."""
        assert self.expect is not None, "only called while an expectation runs"
        self.seg_t_s = t_s
        self._seg_pos_deg = self.expect.position(float(t_s))

    def start(self, axis: AxisMotor, t_s: float, readback_deg: float) -> None:
        """A command went out: expect motion from the read-back position, from rest (the
        belief may think the motor is still running when the real one already stopped, so
        the full start delay is allowed)."""
        at_rest = (self.expect is None or self.still_since_s is not None
                   or not self.expect.moving(t_s))
        if self.ref_t_s is not None and abs(readback_deg - self.ref_pos_deg) < (
                axis.resolution_deg - 1e-9):
            self.carried_deg += self._segment_deg(t_s)   # no motion yet: keep counting
            if self.carried_deg < axis.resolution_deg - 1e-9 and (
                    self.expect is None or not self.expect.moving(t_s)):
                # It had arrived and nothing visible went unseen since: standing still was
                # right until now, so this command's settle time starts now - not at the end
                # of the last move, or a hold then a command acted on a little late would
                # read as a "stall" as long as the hold.
                self.ref_t_s, self.still_since_s = t_s, None
                self._new_series()
        else:
            self.ref_t_s, self.ref_pos_deg, self.carried_deg = t_s, readback_deg, 0.0
            self.still_since_s = None
            self._new_series()
        self.expect = AxisMotor(axis.min_deg, axis.max_deg, axis.rate_deg_s, axis.start_delay_s,
                                axis.resolution_deg, readback_deg, t_s)
        self.expect.command(axis.target_deg, t_s)
        self._new_segment(t_s)
        if not self.send_times:
            self._series_at_rest = at_rest
        self._sent(t_s, abs(float(self.expect.target_deg) - readback_deg)
                   >= axis.resolution_deg - 1e-9)

    def _new_series(self) -> None:
        self._told_t_s = None
        # Most cycles find the series empty already (motion seen, or on target, each cycle).
        if self.send_times or self.copy_times:
            self.send_times, self.asked, self.copy_times = [], [], []

    def _sent(self, t_s: float, asked_travel: bool) -> None:
        self.send_times.append(t_s)
        self.asked.append(asked_travel)

    @property
    def sends(self) -> int:
        return len(self.send_times)

    @property
    def last_send_t_s(self) -> float | None:
        return self.send_times[-1] if self.send_times else None

    def resent(self, t_s: float) -> None:
        """A copy of the last command went out. The expectation keeps running from the first
        send (a controller that got it is on its way); only the count and the time of the
        last chance change."""
        if self.expect is None:
            return
        self.copy_times.append(t_s)
        self._sent(t_s, self.asked[-1] if self.asked else True)

    def _moved(self, t_s: float, readback_deg: float, seen: bool) -> None:
        """Motion ``seen`` (else the axis is at its target, having asked for no travel or
        come back unseen): restart the expectation from here."""
        expect = self.expect
        assert expect is not None, "only called while an expectation runs"
        self.ref_t_s, self.ref_pos_deg = t_s, readback_deg
        if expect.rests_on(readback_deg):
            # Most cycles of a healthy pass: on target, as the cycle before. Restarting it
            # would change nothing its positions depend on.
            self.seg_t_s, self._seg_pos_deg = t_s, readback_deg
        else:
            # In place: on a healthy pass this runs every cycle (motion seen).
            restart_axis(expect, readback_deg, expect.target_deg, t_s, expect.moving(t_s))
            self._new_segment(t_s)
        self.carried_deg = 0.0
        self.still_since_s = None
        if seen and self.send_times:
            self.acted_on = self._series_at_rest
            if self.acted_on:
                self.ack_sends = tuple(self.send_times)
        self._new_series()

    def check(self, t_s: float, readback_deg: float, resolution_deg: float,
              stall_travel_deg: float) -> float | None:
        """Seconds without motion when the axis counts as stalled, else None."""
        expect = self.expect
        if expect is None or self.ref_t_s is None:
            return None
        ref_deg = self.ref_pos_deg
        if readback_deg == ref_deg and expect.rests_on(readback_deg):
            # Most cycles of a healthy pass: on target, as the cycle before (no motion
            # seen, at the target: the branch below, without working that out).
            self._moved(t_s, readback_deg, seen=False)
            return None
        target_deg = expect.target_deg
        step_deg = resolution_deg - 1e-9
        moved = abs(readback_deg - ref_deg)
        if moved >= step_deg or abs(readback_deg - target_deg) < step_deg:
            # At the target is never a stall: a command asking for no travel, or a rotator
            # faster than its model that went out and came back between two read-backs.
            # Motion counts as the controller acting on a command only toward the target: a
            # reading with a digit garbled into another valid one may jump anywhere.
            toward = (readback_deg - ref_deg) * (target_deg - ref_deg) > 0
            self._moved(t_s, readback_deg, seen=moved >= step_deg and toward)
            return None
        if self.still_since_s is None:
            self.still_since_s = t_s
        expected = self.carried_deg + self._segment_deg(t_s)
        # Timing jitter (a late read-back, a belief a cycle off) must not look like a stall:
        # judge only after the start delay plus a second, and only on read-backs spanning
        # that long. A W has no acknowledgement: if the controller acted on it late (a busy
        # host, a time-compressed simulation), the first read-backs after it show no motion
        # yet although the belief's clock says the motor ran long ago.
        settle_s = expect.start_delay_s + 1.0
        if (expected >= stall_travel_deg and t_s - self.ref_t_s >= settle_s
                and t_s - self.still_since_s >= settle_s):
            return t_s - self.ref_t_s
        return None

    @property
    def copies(self) -> int:
        return len(self.copy_times)

    def told_at(self, other_ack_sends: tuple[float, ...]) -> float | None:
        """When the controller last acted on a command that asked this axis to move, or
        None if that is not known: this axis moved on one sent while it stood still and
        nothing new went out since (-inf: before every send in the series), or another axis
        started on one of this axis's sends (``other_ack_sends``; each asked this one to
        move too). It may have been a garbled copy naming another target, so one more send
        after it is still worth its time; more cannot help."""
        if self.sends == self.copies and self.acted_on:
            return -math.inf
        if self._told_t_s is None and other_ack_sends:   # the first known arrival counts
            moving = {t for t, a in zip(self.send_times, self.asked, strict=True) if a}
            if set(other_ack_sends) <= moving:
                self._told_t_s = max(other_ack_sends)
        return self._told_t_s

    def sends_after(self, t_s: float) -> list[float]:
        return [t for t in self.send_times if t > t_s]

    def _visible_after_s(self) -> float:
        """From rest, a healthy axis shows motion on whole-degree read-back this long after
        it was told to move (acted on when sent)."""
        e = self.expect
        assert e is not None, "only called while an expectation runs"
        return e.start_delay_s + e.resolution_deg / e.rate_deg_s

    def motion_overdue(self, t_s: float, resolution_deg: float) -> bool:
        """No motion seen although the commands, acted on when sent, would show some by
        now: the first sign of a lost command (or a jam)."""
        if self.expect is None or self.ref_t_s is None:
            return False
        since = self.send_times[-1] if self.send_times else self.ref_t_s
        if not t_s > since:      # (motion was seen, or a command sent, just now)
            return False
        return self.carried_deg + self._segment_deg(t_s) >= resolution_deg - 1e-9

    def had_time_since(self, t_s: float, sent_t_s: float) -> bool:
        """Since ``sent_t_s`` the axis had the time to show motion from rest."""
        return t_s - sent_t_s >= self._visible_after_s()

    def sends_had_their_chance(self, t_s: float, sends: int) -> bool:
        """At least ``sends`` commands (new ones or copies) went out since motion was last
        seen, and since the ``sends``-th the axis had the time to show motion from rest (one
        resolution step: whole-degree read-back of a rest position changes with the first
        full degree), acted on when sent. Later sends do not restart the wait: in a fast
        stretch a new command goes out every cycle, each asking for travel the same way."""
        if self.expect is None or self.sends < max(sends, 1):
            return False
        return t_s - self.send_times[max(sends, 1) - 1] >= self._visible_after_s()

    def observation(self, t_s: float) -> Observation:
        target = self.expect.target_deg if self.expect is not None else float("nan")
        since = self.ref_t_s if self.ref_t_s is not None else t_s
        return Observation(self.ref_pos_deg, t_s - since, max(self.sends, 1), target)


def moving_axis(template: AxisMotor, position_deg: float, target_deg: float, t_s: float,
                moving: bool) -> AxisMotor:
    """An axis like ``template`` standing at ``position_deg`` at ``t_s``; when ``moving`` it is
    already running toward ``target_deg`` at ``t_s`` (its start delay is behind it)."""
    a = AxisMotor(template.min_deg, template.max_deg, template.rate_deg_s,
                  template.start_delay_s, template.resolution_deg)
    restart_axis(a, position_deg, target_deg, t_s, moving)
    return a


def restart_axis(axis: AxisMotor, position_deg: float, target_deg: float, t_s: float,
                 moving: bool) -> None:
    """:func:`moving_axis` on ``axis`` itself (its own rates and limits, not jammed)."""
    delay = axis.start_delay_s
    axis.rest_at(position_deg, t_s - delay)
    if moving and abs(target_deg - position_deg) > 1e-9:
        axis.command(target_deg, t_s - delay)  # the start delay ends exactly at t_s


# Tables running on the controller ------------------------------------------------------

# Read-backs are whole degrees: from a read-back that sits on its table point
# (the antenna is exactly there) the model must predict >= STALL_MOVE_DEG of travel; from one
# taken mid-move (up to 0.5 deg off the real position) >= STALL_MOVE_DEG + 0.5. The axis has
# stalled when it then shows < STILL_DEG of progress toward the point, read twice (a
# garbled digit must not stop a pass).
STALL_MOVE_DEG = 1.0
STALL_HISTORY_S = 8.0
# Command times are the host's; the controller may step a little late (clock drift up to the
# resync slack is measured from N, this covers the poll and the emulator/controller tick).
STALL_TIMING_MARGIN_S = 0.25
# Without a RotatorSpec the model assumes a slow rotator (slower than every preset, at 50 Hz
# too), so a healthy one is never predicted further than it can be; a jam is then caught a
# little later.
FALLBACK_RATE_DEG_S = 2.0
FALLBACK_START_DELAY_S = 0.75
# ... and, for a table that goes away and comes back (a 1-deg el flicker 2, 3, 2), a FAST
# one: the antenna may be back already, so a stall must be predicted by both models.
FALLBACK_FAST_RATE_DEG_S = 10.0
FALLBACK_FAST_START_DELAY_S = 0.2


class TableWatch:
    """Is each axis moving toward the table as the shared motor model says it must?

    Keeps the recent C2 read-backs of the active table. For each one (the reference) an
    :class:`~tracker.mount.AxisMotor` is put at rest on the reference reading and driven by
    :func:`~tracker.mount.drive_axis` through the point active then and the points due
    since, at their (late-shifted) command times. Starting from rest adds a start delay the
    real motor may not need, so a healthy axis is always at least as far along as predicted:
    if the model has it >= 1 deg further toward the point and the read-back shows no progress,
    the axis is not turning. Points equal to the previous one, a rotator waiting on a point
    and start delays all predict no travel, so they never count.
    """

    def __init__(self, spec: RotatorSpec | None):
        self.spec = spec
        self.table: StepTable | None = None
        self.readings: list[tuple[float, float, float, float | None]] = []
        self._times = np.zeros(0)
        self._lag_s = 0.0

    def start(self, table: StepTable, uploaded_t_s: float) -> None:
        """A (re)uploaded table: point 1 is commanded when the line has landed."""
        self.table = table
        self.readings = []
        self._lag_s = 0.0
        self._times = table.command_times().astype(float)
        self._times[0] = max(self._times[0], uploaded_t_s)

    def t_sent(self, t_s: float) -> None:
        """T went out at ``t_s``: the controller steps from then on (a late T, e.g. after a
        slow paced upload, shifts every later point)."""
        if len(self._times) > 1:
            self._times[1:] += max(0.0, t_s - float(self._times[1]))

    def note_index(self, current: int, t_s: float) -> None:
        """N said point ``current`` (1-based) at ``t_s``: the next one was not yet due there,
        so the controller runs at least that late (drift within the resync slack)."""
        if 0 < current < len(self._times):
            self._lag_s = max(self._lag_s, t_s - float(self._times[current]))

    def add(self, t_before: float, t_after: float, az: float, el: float | None) -> None:
        self.readings.append((t_before, t_after, az, el))
        cut = t_before - STALL_HISTORY_S
        self.readings = [r for r in self.readings if r[0] >= cut]

    def _axes(self, which: str, position_deg: float, t_s: float) -> list[AxisMotor]:
        """The slowest and the fastest motor the axis may be (at rest at the reading)."""
        spec = self.spec
        if spec is None:
            models = [(FALLBACK_RATE_DEG_S, FALLBACK_START_DELAY_S),
                      (FALLBACK_FAST_RATE_DEG_S, FALLBACK_FAST_START_DELAY_S)]
        else:
            rate = spec.az_rate_deg_s if which == "az" else (spec.el_rate_deg_s or 1.0)
            slow = rate
            if which == "az" and spec.az_speed_rates_deg_s:
                slow = min(rate, *spec.az_speed_rates_deg_s)   # X1 may be selected
                rate = max(rate, *spec.az_speed_rates_deg_s)
            models = [(slow, spec.start_delay_s), (rate, spec.start_delay_s)]
        return [AxisMotor(-1e9, 1e9, r, d, 1.0, position_deg, t_s) for r, d in models]

    def stalled(self, t_s: float, az: float, el: float | None,
                t_after_s: float | None = None) -> tuple[str, str] | None:
        """("az"/"el", what is wrong) if an axis read between ``t_s`` and ``t_after_s`` (the
        C2 request and its reply) should have moved and has not, else None.

        The controller took the reading somewhere in that span (at a fast SimClock or on a
        loaded host it can be a second or more), so the model must have the axis at least
        ``need`` away from the reference at EVERY time in it, on the same side: a 1-deg
        up-and-back flicker of the table (2, 3, 2) is otherwise mistaken for a jam when the
        reply comes from after the axis already went back.
        """
        table = self.table
        if table is None or not self.readings:
            return None
        t_hi = t_s if t_after_s is None else max(float(t_after_s), t_s)
        t_eval = np.linspace(t_s, t_hi, 9) if t_hi > t_s else np.array([t_s])
        base = self._times.copy()
        base[1:] += self._lag_s
        axes = [("az", 2, az, np.asarray(table.az_deg, dtype=float))]
        if table.kind == "W" and el is not None and table.el_deg is not None:
            axes.append(("el", 3, el, np.asarray(table.el_deg, dtype=float)))
        for name, col, now_deg, points in axes:
            for ref in self.readings:
                t_ref, ref_deg = ref[1], ref[col]
                if ref_deg is None or t_ref >= t_s:
                    continue
                # The controller steps at the host's times or up to the margin later; the
                # axis is the slow or the fast motor: a stall must show in every case.
                travels = []
                for shift in (STALL_TIMING_MARGIN_S, 0.0):
                    got = self._travel(name, base + shift, points, ref_deg, t_ref, t_hi,
                                       t_eval)
                    if got is None:
                        break
                    travels.append(got)
                else:
                    allt = np.concatenate([t for t, _ in travels])
                    if np.min(allt) * np.max(allt) <= 0.0:
                        continue     # some timing has the axis back at (or past) the reading
                    travel, cmd_last = float(travels[0][0][0]), travels[0][1]
                    progress = (now_deg - ref_deg) * np.sign(travel)
                    if progress < STILL_DEG:
                        return name, (f"reads {now_deg:g} deg, {t_s - t_ref:.1f} s after it "
                                      f"read {ref_deg:g}; the motor model has it at "
                                      f"{ref_deg + travel:.1f} by now (table point "
                                      f"{cmd_last:g})")
        return None

    def _travel(self, name: str, times: np.ndarray, points: np.ndarray, ref_deg: float,
                t_ref: float, t_hi: float, t_eval: np.ndarray
                ) -> tuple[np.ndarray, float] | None:
        """Predicted travel from the reading ``ref_deg`` at ``t_ref`` at each ``t_eval``
        (slow motor first, then fast), and the last point commanded; None when this
        schedule predicts less than the move needed to tell a stall (or cannot judge)."""
        i0 = int(np.searchsorted(times, t_ref, side="right")) - 1
        i1 = int(np.searchsorted(times, t_hi, side="right"))
        if i0 < 0:          # nothing commanded yet at the reference
            i0 = 0
            if i1 == 0:
                return None
            cmd_t = times[:i1]
        else:
            cmd_t = np.concatenate(([t_ref], times[i0 + 1:i1]))
        cmd_deg = points[i0:i1] if i1 > i0 else points[i0:i0 + 1]
        cmd_t = cmd_t[:len(cmd_deg)]
        if name == "az" and abs(float(cmd_deg[0]) - ref_deg) > 180.0:
            return None     # an unwind or a different az frame: leave it to the span check
        exact = abs(float(points[i0]) - ref_deg) < 0.25 and t_ref >= times[i0]
        need = STALL_MOVE_DEG + (0.0 if exact else 0.5)
        out = []
        for axis in self._axes(name, ref_deg, t_ref):
            travel = drive_axis(axis, cmd_t, cmd_deg, t_eval)[0] - ref_deg
            if np.min(np.abs(travel)) < need - 1e-6:
                return None
            out.append(travel)
        return np.concatenate(out), float(cmd_deg[-1])
