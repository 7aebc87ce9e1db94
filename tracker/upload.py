"""Upload step tables and run them: pre-position, T on time, monitor, resync, all-stop.

The procedure for each table of a :class:`~tracker.steptable.StepProgram` (or a plan file):

1. wait on the Clock until the table's upload time (for the first table: before AOS, early
   enough for the slew to point 1; for a chained table: one wire time before its boundary),
   then send the long-form line(s) through the driver (its flow control and pacing);
2. wait until the T time and send ``T``;
3. monitor until the next table is due: ``N`` must report all the points (a short count is a
   truncated upload) and the index the host clock expects (a different index is drift or a
   lost step; no list at all is a power cycle); any of these → resync by uploading the
   remaining points and sending ``T`` again at the next point's time. An ``N`` reply that
   cannot be read (line noise, a timeout) is asked again, and a bad count is confirmed by a
   second ``N``, before anything is concluded: noise must not cost a resync. ``C2`` must show
   each axis moving toward the table: :class:`_StallWatch` drives the shared motor model
   (:func:`tracker.mount.predict_axis`) from each recent read-back through the points due
   since, and an axis the model says must have moved >= 1 deg that has not moved at all (read
   twice) is a jam: all-stop and :class:`~tracker.errors.StallError`, within about
   start delay + 1 deg of travel + one poll of the point change.

Every exit path (end, error, Ctrl-C) sends all-stop, except ``detach`` after a successful T
(the controller is meant to go on by itself).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from tracker.clock import Clock
from tracker.errors import (
    ConfigError,
    ProtocolError,
    RotatorIOError,
    StallError,
    TrackerError,
)
from tracker.mount import AxisMotor, RotatorSpec, predict_axis
from tracker.protocols.gs232 import is_error_reply
from tracker.steptable import BITS_PER_BYTE, StepTable

# Reading N at a step boundary may see either side; allow this much clock slack.
INDEX_SLACK_S = 0.6
# How many resyncs before the host gives up (stops the rotator and reports).
MAX_RESYNCS = 5
# An unreadable N / C2 reply (garbled, cut short) is asked again this many times in
# one poll; only this many polls in a row without a readable N count as a lost controller.
READ_ATTEMPTS = 3
UNREADABLE_POLLS = 3

# Stall detection. Read-backs are whole degrees: from a read-back that sits on its table point
# (the antenna is exactly there) the model must predict >= STALL_MOVE_DEG of travel; from one
# taken mid-move (up to 0.5 deg off the real position) >= STALL_MOVE_DEG + 0.5. The axis has
# stalled when it then shows < STALL_STILL_DEG of progress toward the point, read twice (a
# garbled digit must not stop a pass).
STALL_MOVE_DEG = 1.0
STALL_STILL_DEG = 0.5
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


@dataclass
class UploadReport:
    """What happened, for the CLI and the tests."""

    tables_sent: int = 0
    uploads: list[dict] = field(default_factory=list)   # bytes, wire_s, upload_s
    t_late_s: list[float] = field(default_factory=list)  # T sent minus T due (clock s)
    resyncs: list[str] = field(default_factory=list)
    polls: int = 0
    detached: bool = False
    stopped: bool = False
    events: list[str] = field(default_factory=list)


class TableRunner:
    """Runs tables on one driver against one Clock (see the module docstring).

    ``baud`` is used to predict the wire time of an upload (``bytes * 10 / baud``), which
    decides when a chained table's upload must start. ``poll_s`` is the monitoring period
    (clock seconds; default: half the step period, within 1..5 s). ``follow_tol_deg`` is how
    far outside the recently commanded points the antenna may read before it counts as not
    following (twice in a row → stall; a coarse backstop to the motor-model check). ``spec``
    gives the motor model its rates and start delay (a slow generic rotator without it).
    """

    def __init__(self, driver, clock: Clock, *, baud: int = 9600, poll_s: float | None = None,
                 follow_tol_deg: float = 4.0, follow_window_s: float = 40.0,
                 log: Callable[[str], None] | None = None, monitor: bool = True,
                 spec: RotatorSpec | None = None):
        self.driver = driver
        self.clock = clock
        self.baud = int(baud)
        self.poll_s = poll_s
        self.follow_tol_deg = float(follow_tol_deg)
        self.follow_window_s = float(follow_window_s)
        self.log = log or (lambda _msg: None)
        self.monitor = monitor
        self.report = UploadReport()
        self._misses = 0
        self._off_deg: float | None = None
        self._unreadable = 0
        self._watch = _StallWatch(spec)

    # Public --------------------------------------------------------------------------------

    def run(self, tables: Sequence[StepTable], *, detach: bool = False) -> UploadReport:
        if not tables:
            raise ConfigError("nothing to upload: no tables")
        if detach and len(tables) > 1:
            raise ConfigError(f"--detach needs a single table but this pass needs "
                              f"{len(tables)} chained ones (the host sends each next table); "
                              f"use a longer --interval or stay attached")
        for table in tables:
            table.lines()  # refuse anything over the limits before a single byte is sent
        ok = False
        try:
            if tables[0].profile.lines_append:
                # K3NG appends W lines to whatever list is left: S clears it first.
                self.driver.stop()
            for k, table in enumerate(tables):
                nxt = tables[k + 1].upload_t_s if k + 1 < len(tables) else None
                self._run_one(table, k, len(tables), detach, nxt)
                if self.report.detached:
                    ok = True
                    return self.report
            ok = True
            return self.report
        finally:
            # A stall has already sent all-stop (and logged it); once is enough.
            if not (ok and self.report.detached) and not self.report.stopped:
                self._all_stop(quiet=not ok)

    # Steps ---------------------------------------------------------------------------------

    def _run_one(self, table: StepTable, k: int, n: int, detach: bool,
                 next_upload_t_s: float | None) -> None:
        self._wait_until(table.upload_t_s)
        self._upload(table, f"table {k + 1}/{n}")
        self._send_t(table)
        if detach:
            self.report.detached = True
            self.log("detached after T: the controller steps through the table by itself")
            return
        until = next_upload_t_s if next_upload_t_s is not None else table.end_t_s
        if self.monitor:
            self._monitor(table, until)
        else:
            self._wait_until(until)

    def _upload(self, table: StepTable, what: str) -> None:
        lines = table.lines()
        nbytes = sum(len(line) + 1 for line in lines)
        wire_s = nbytes * BITS_PER_BYTE / self.baud
        t0 = self.clock.monotonic()
        r0 = time.perf_counter()  # real elapsed time of the I/O itself, for the report
        for line in lines:
            self._send_line(table, line)
        upload_s = self.clock.monotonic() - t0
        self.report.uploads.append({"what": what, "points": len(table), "bytes": nbytes,
                                    "wire_s": wire_s, "upload_s": upload_s,
                                    "upload_real_s": time.perf_counter() - r0})
        self.report.tables_sent += 1
        self._watch.start(table, self.clock.timestamp())
        self._off_deg = None
        self.log(f"uploaded {what}: {len(table)} points, {nbytes} bytes in "
                 f"{upload_s:.2f} s (wire time at {self.baud} baud {wire_s:.2f} s)")

    def _send_line(self, table: StepTable, line: str) -> None:
        # The driver encodes the same line from the points (shared codec) and applies the
        # profile's flow control and pacing; cross-check so what we logged is what went out.
        from tracker.steptable import parse_table_line

        kind, sss, nums = parse_table_line(line)
        points = list(zip(nums[0::2], nums[1::2], strict=True)) if kind == "W" else nums
        self.driver.upload_table(sss, points)

    def _send_t(self, table: StepTable) -> None:
        self._wait_until(table.start_t_s)
        self.driver.start_table()
        self._watch.t_sent(self.clock.timestamp())
        late = self.clock.timestamp() - table.start_t_s
        self.report.t_late_s.append(late)
        self.log(f"T sent ({late * 1000:+.0f} ms)")

    def _monitor(self, table: StepTable, until_t_s: float) -> None:
        active = table
        poll = self.poll_s or float(np.clip(table.period_s / 2.0, 1.0, 5.0))
        while True:
            now = self.clock.timestamp()
            if now >= until_t_s - 1e-3:
                return
            self.clock.sleep(min(poll, until_t_s - now))
            now = self.clock.timestamp()
            if now >= until_t_s - 1e-3:
                return
            problem = self._check_status(active, now)
            if problem:
                rest = self._resync(active, problem)
                if rest is None:  # one point left, sent short-form: nothing to step through
                    self._wait_until(until_t_s)
                    return
                active = rest
                continue
            self._check_follows(active)

    def _check_status(self, table: StepTable, now: float) -> str | None:
        """None if N agrees with the host clock (or cannot be read this poll), else what is
        wrong. A problem is only reported when a second N shows it too."""
        if table.profile.clears_at_end and \
                now >= table.command_times()[-1] - INDEX_SLACK_S:
            return None  # the list is gone once the last point is reached, by design (K3NG)
        first = self._status_problem(table)
        if first is None:
            return None
        if first == "unreadable":
            self._unreadable += 1
            if self._unreadable < UNREADABLE_POLLS:
                self.log(f"N unreadable ({self._unreadable} poll(s) in a row); asking again "
                         "next poll")
                return None
            self._unreadable = 0
            return (f"controller has no table any more or does not answer N ({UNREADABLE_POLLS} "
                    "polls without a readable reply; power cycle or reset?)")
        second = self._status_problem(table)
        if second is None or second == "unreadable":
            self.log(f"N: {first}, not confirmed by a second N (line noise?); carrying on")
            return None
        return second

    def _status_problem(self, table: StepTable) -> str | None:
        """One N reading (asked again on noise): None, "unreadable" or the problem."""
        for _attempt in range(READ_ATTEMPTS):
            t_before = self.clock.timestamp()
            try:
                current, total = self.driver.table_status()
            except ProtocolError as e:
                if is_error_reply(e.raw):
                    return f"controller has no table any more (power cycle or reset?): {e}"
                self.log(f"N unreadable: {e}")
                continue
            # RotatorTimeout propagates: the driver has already asked 1 + retries times, and a
            # silent controller (port lost, cable out) must surface, not be polled for ever.
            t_after = self.clock.timestamp()
            self.report.polls += 1
            self._unreadable = 0
            if total != len(table):
                return f"controller holds {total} of {len(table)} points (truncated upload)"
            if current is None:
                return None
            lo = table.index_at(t_before - INDEX_SLACK_S)
            hi = table.index_at(t_after + INDEX_SLACK_S)
            if not lo <= current <= hi:
                return (f"controller is on point {current}, the host clock says {lo}"
                        + (f"..{hi}" if hi != lo else "") + " (drift or a lost step)")
            self._watch.note_index(current, t_before)
            return None
        return "unreadable"

    def _resync(self, table: StepTable, problem: str) -> StepTable | None:
        self.report.resyncs.append(problem)
        self.log(f"resync: {problem}")
        if len(self.report.resyncs) > MAX_RESYNCS:
            raise RotatorIOError(f"gave up after {MAX_RESYNCS} resyncs; last problem: "
                                 f"{problem}. The rotator was stopped")
        now = self.clock.timestamp()
        wire_s = table.wire_time_s(self.baud)
        rest = table.remaining_from(now, wire_s)
        if rest is None:
            last = table.points[-1]
            az, el = (last if table.kind == "W" else (last, None))
            self.driver.goto(az, el)
            self.log("resync: one point left, sent it as a short command")
            return None
        self._upload(rest, f"resync ({len(rest)} remaining points)")
        self._send_t(rest)
        return rest

    def _read_position(self) -> tuple[float, float, float, float | None] | None:
        """(t_before, t_after, az, el) from C2, asked again on noise; None if unreadable."""
        for _attempt in range(READ_ATTEMPTS):
            t_before = self.clock.timestamp()
            try:
                az, el = self.driver.position()
            except ProtocolError as e:      # garbled; silence propagates as for N
                self.log(f"C2 unreadable: {e}")
                continue
            return t_before, self.clock.timestamp(), float(az), el
        return None

    def _check_follows(self, table: StepTable) -> None:
        """Each axis must move toward its table point as the motor model says (a jam is
        caught within seconds); C2 must also read within the span of the recently commanded
        points (± tolerance), a coarse backstop."""
        if not np.isfinite(table.end_t_s) or len(table) == 0:
            return
        read = self._read_position()
        if read is None:
            return
        t_before, t_after, az, el = read
        stalled = self._watch.stalled(t_before, az, el, t_after)
        if stalled is not None:
            again = self._read_position()       # a garbled digit must not stop a pass
            if again is not None:
                t_before, t_after, az, el = again
                stalled = self._watch.stalled(t_before, az, el, t_after)
            if stalled is not None and again is not None:
                axis, msg = stalled
                self.log(f"stall: {msg}")
                self._all_stop(quiet=True)
                raise StallError(f"the antenna is not following the table: the {axis} axis "
                                 f"{msg}; stopped the rotator. Check the motors, the control "
                                 "box power and the cabling")
        self._watch.add(t_before, t_after, az, el)

        now = self.clock.timestamp()
        times = table.command_times()
        if now < table.start_t_s:
            return
        recent = (times >= now - self.follow_window_s - table.period_s) & (times <= now)
        recent[max(np.searchsorted(times, now, side="right") - 1, 0)] = True
        az_pts = np.asarray(table.az_deg)[recent].astype(float)
        off_deg = _outside_by(az, az_pts, self.follow_tol_deg, wrap=True)
        if table.kind == "W" and el is not None:
            el_pts = np.asarray(table.el_deg)[recent].astype(float)
            off_deg += _outside_by(el, el_pts, self.follow_tol_deg, wrap=False)
        # Outside the span but closing in is a slew still under way (a resumed or resynced
        # table whose point 1 is far from the antenna): not a miss.
        closing = self._off_deg is not None and off_deg < self._off_deg - STALL_STILL_DEG
        self._off_deg = off_deg
        self._misses = self._misses + 1 if off_deg > 0.0 and not closing else 0
        if self._misses >= 2:
            msg = (f"the antenna is not following the table: reads az {az:g}"
                   + ("" if el is None else f" el {el:g}")
                   + f", commanded az {az_pts.min():g}..{az_pts.max():g}; stopped the rotator."
                   " Check the motors, the control box power and the cabling")
            self._all_stop(quiet=True)
            raise StallError(msg)

    # Helpers ------------------------------------------------------------------------------

    def _wait_until(self, t_s: float) -> None:
        # Sleep in slices so a Ctrl-C lands promptly even with a long wait before AOS.
        while True:
            left = t_s - self.clock.timestamp()
            if left <= 0:
                return
            self.clock.sleep(min(left, 1.0))

    def _all_stop(self, quiet: bool) -> None:
        try:
            self.driver.stop()
            self.report.stopped = True
            self.log("all-stop sent")
        except TrackerError:
            if not quiet:
                raise


def _outside_by(value: float, points: np.ndarray, tol: float, wrap: bool) -> float:
    """How far (deg) ``value`` lies outside the span of ``points`` ± ``tol`` (0 inside)."""
    lo, hi = float(points.min()) - tol, float(points.max()) + tol
    candidates = (value, value + 360.0, value - 360.0) if wrap else (value,)
    return min(max(lo - v, v - hi, 0.0) for v in candidates)



def resume_schedule(tables: Sequence[StepTable], now_s: float, baud: int = 9600
                    ) -> list[StepTable]:
    """The tables still to send at ``now_s``: finished ones dropped, a started one resumed
    from the point due when a fresh upload lands. Raises ConfigError if the pass is over."""
    out: list[StepTable] = []
    for table in tables:
        if table.end_t_s <= now_s:
            continue
        if table.upload_t_s >= now_s:
            out.append(table)
            continue
        rest = table.remaining_from(now_s, table.wire_time_s(baud))
        if rest is not None:
            out.append(rest)
    if not out:
        raise ConfigError("the pass in this plan is over; nothing left to send. Plan the next "
                          "pass (`tracker plan ... --steptable FILE`)")
    return out


class _StallWatch:
    """Is each axis moving toward the table as the shared motor model says it must?

    Keeps the recent C2 read-backs of the active table. For each one (the reference) an
    :class:`~tracker.mount.AxisMotor` is put at rest on the reference reading and driven by
    :func:`~tracker.mount.predict_axis` through the point active then and the points due
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
                    if progress < STALL_STILL_DEG:
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
            travel = predict_axis(axis, cmd_t, cmd_deg, t_eval)[0] - ref_deg
            if np.min(np.abs(travel)) < need - 1e-6:
                return None
            out.append(travel)
        return np.concatenate(out), float(cmd_deg[-1])
