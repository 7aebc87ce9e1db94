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
   each axis moving toward the table: :class:`tracker.stall.TableWatch` drives the shared
   motor model (:func:`tracker.mount.drive_axis`) from each recent read-back through the
   points due since, and an axis the model says must have moved >= 1 deg that has not moved at
   all (read twice) is a jam: all-stop and :class:`~tracker.errors.StallError`, within about
   start delay + 1 deg of travel + one poll of the point change.

Given the target's sky track (``sky``) and the rotator (``spec``), each read-back during the
pass is also compared with where the target is at that moment
(:func:`tracker.geometry.pointing_error_deg`): the measured pointing error, in the progress
lines and, as its maximum, in the report.

Every exit path (end, error, Ctrl-C) sends all-stop, except ``detach`` after a successful T
(the controller is meant to go on by itself).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from tracker.clock import Clock
from tracker.errors import (
    ConfigError,
    LimitError,
    ProtocolError,
    RotatorIOError,
    TrackerError,
    with_advice,
)
from tracker.geometry import pointing_error_deg
from tracker.mount import RotatorSpec
from tracker.protocols.gs232 import is_error_reply
from tracker.protocols.gs232_tables import decode_table_line
from tracker.stall import STILL_DEG, TableWatch, stall_error
from tracker.steptable import BITS_PER_BYTE, MAKE_PLAN, StepTable

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.skytrack import SkyTrack

# Reading N at a step boundary may see either side; allow this much clock slack.
INDEX_SLACK_S = 0.6
# How many resyncs before the host gives up (stops the rotator and reports).
MAX_RESYNCS = 5
# An unreadable N / C2 reply (garbled, cut short) is asked again this many times in
# one poll; only this many polls in a row without a readable N count as a lost controller.
READ_ATTEMPTS = 3
UNREADABLE_POLLS = 3
# Progress lines (what the runner waits for, the step it is on): this often (clock s), and
# once a minute while the wait is longer than two.
PROGRESS_S = 10.0
PROGRESS_LONG_S = 60.0

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
    errors_deg: list[float] = field(default_factory=list)  # measured, one per read-back

    @property
    def max_error_deg(self) -> float | None:
        """The largest measured pointing error of the pass; None when none was measured
        (no sky track, detached, or no readable read-back during the pass)."""
        return max(self.errors_deg) if self.errors_deg else None


class TableRunner:
    """Runs tables on one driver against one Clock (see the module docstring).

    ``baud`` is used to predict the wire time of an upload (``bytes * 10 / baud``), which
    decides when a chained table's upload must start. ``poll_s`` is the monitoring period
    (clock seconds; default: half the step period, within 1..5 s). ``follow_tol_deg`` is how
    far outside the recently commanded points the antenna may read before it counts as not
    following (twice in a row → stall; a coarse backstop to the motor-model check). ``spec``
    gives the motor model its rates and start delay (a slow generic rotator without it).
    ``sky`` (anything with ``direction_at(t_s) -> (bearing_deg, el_deg)``, e.g. the
    :class:`~tracker.skytrack.SkyTrack` the tables were compiled from) with ``spec`` turns
    each read-back during the pass into a measured pointing error. ``progress`` gets the
    periodic lines (the step the table is on, the wait left; default: ``log``), so a
    service can show them on a status page instead of its log; ``on_reading(t_s,
    wire_az_deg, el_deg, error_deg)`` hears each read-back and its measured error (None
    outside the pass).
    """

    def __init__(self, driver, clock: Clock, *, baud: int = 9600, poll_s: float | None = None,
                 follow_tol_deg: float = 4.0, follow_window_s: float = 40.0,
                 log: Callable[[str], None] | None = None, monitor: bool = True,
                 spec: RotatorSpec | None = None, sky: SkyTrack | None = None,
                 progress: Callable[[str], None] | None = None,
                 on_reading: Callable[[float, float, float | None, float | None], None]
                 | None = None):
        self.driver = driver
        self.clock = clock
        self.baud = int(baud)
        self.poll_s = poll_s
        self.follow_tol_deg = float(follow_tol_deg)
        self.follow_window_s = float(follow_window_s)
        self.log = log or (lambda _msg: None)
        self.progress = progress or self.log
        self.on_reading = on_reading
        self.monitor = monitor
        self.report = UploadReport()
        self._misses = 0
        self._off_deg: float | None = None
        self._unreadable = 0
        self._watch = TableWatch(spec)
        self._last_read: tuple[float, float | None] | None = None   # last C2: az, el
        self._said_t_s = -float("inf")                              # last progress line
        self._spec = spec
        self._sky = sky
        self._pass_s = (float("inf"), -float("inf"))  # first T .. last point's hold end
        self._last_error_deg: float | None = None

    # Public --------------------------------------------------------------------------------

    def run(self, tables: Sequence[StepTable], *, detach: bool = False) -> UploadReport:
        if not tables:
            raise ConfigError("nothing to upload: no tables")
        if detach and len(tables) > 1:
            raise with_advice(ConfigError,
                              f"detach needs a single table but this pass needs {len(tables)} "
                              f"chained ones (the host sends each next table)",
                              "; compile it with a longer interval_s or stay attached")
        for table in tables:
            table.lines()  # refuse anything over the limits before a single byte is sent
        self._check_controller_limits(tables)
        self._pass_s = (tables[0].start_t_s, tables[-1].end_t_s)
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

    def _check_controller_limits(self, tables: Sequence[StepTable]) -> None:
        """Refuse (LimitError, nothing sent) a table with a point beyond what the driver
        reports the controller accepts, instead of failing at that table's upload, maybe
        mid-pass; compile the pass for the controller's effective limits instead."""
        caps = getattr(self.driver, "capabilities", None)
        if caps is None:
            return
        for n, table in enumerate(tables, 1):
            az_hi = float(np.max(table.az_deg))
            if az_hi > caps.az_max_deg + 1e-9:
                raise LimitError(f"table {n} turns to azimuth {az_hi:g}, but the controller "
                                 f"takes azimuth up to {caps.az_max_deg:g}")
            if table.el_deg is not None and len(table.el_deg):
                el_hi = float(np.max(table.el_deg))
                if el_hi > caps.el_max_deg + 1e-9:
                    raise LimitError(f"table {n} turns to elevation {el_hi:g}, but the "
                                     f"controller takes elevation up to {caps.el_max_deg:g}")

    # Steps ---------------------------------------------------------------------------------

    def _run_one(self, table: StepTable, k: int, n: int, detach: bool,
                 next_upload_t_s: float | None) -> None:
        self._wait_until(table.upload_t_s, f"upload of table {k + 1}/{n}")
        self._upload(table, f"table {k + 1}/{n}")
        if detach:
            self._confirm_loaded(table)
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

    def _confirm_loaded(self, table: StepTable) -> None:
        """Before a T that nobody will watch: the controller must say it holds the whole
        table. A silent or garbled line raises here (the driver asks again first), and the
        run ends with all-stop instead of leaving a controller in an unknown state."""
        _current, total = self.driver.table_status()
        if total != len(table):
            raise ProtocolError(f"the controller holds {total} points of the {len(table)} "
                                f"uploaded; not sending T (detach needs a table that arrived "
                                f"whole)")
        self.log(f"N: the controller holds all {total} points")

    def _send_line(self, table: StepTable, line: str) -> None:
        # The driver encodes the same line from the points (shared codec) and applies the
        # profile's flow control and pacing; cross-check so what we logged is what went out.
        decoded = decode_table_line(line)
        points = (decoded.az if decoded.el is None
                  else list(zip(decoded.az, decoded.el, strict=True)))
        self.driver.upload_table(decoded.interval_s, points)

    def _send_t(self, table: StepTable) -> None:
        self._wait_until(table.start_t_s, "T (the table starts stepping)")
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
            self._say_progress(active)

    def _say_progress(self, table: StepTable) -> None:
        """Every :data:`PROGRESS_S`: the step the table is on and where the antenna reads."""
        now = self.clock.timestamp()
        if now - self._said_t_s < PROGRESS_S:
            return
        self._said_t_s = now
        where = ""
        if self._last_read is not None:
            az, el = self._last_read
            where = f"; antenna reads az {az:g}" + ("" if el is None else f" el {el:g}")
            if self._last_error_deg is not None:
                where += f", {self.error_label} {self._last_error_deg:.1f} deg"
        step = min(table.index_at(now), len(table))
        self.progress(f"step {step}/{len(table)}, {_mmss(table.end_t_s - now)} to the last "
                 f"point{where}")

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
        self._last_read = (az, el)
        self._measure(0.5 * (t_before + t_after), az, el)
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
                raise stall_error(f"the antenna is not following the table: the {axis} "
                                  f"axis {msg}")
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
        closing = self._off_deg is not None and off_deg < self._off_deg - STILL_DEG
        self._off_deg = off_deg
        self._misses = self._misses + 1 if off_deg > 0.0 and not closing else 0
        if self._misses >= 2:
            msg = (f"the antenna is not following the table: reads az {az:g}"
                   + ("" if el is None else f" el {el:g}")
                   + f", commanded az {az_pts.min():g}..{az_pts.max():g}")
            self._all_stop(quiet=True)
            raise stall_error(msg)

    @property
    def error_label(self) -> str:
        """``pointing error``, or ``azimuth error`` for an azimuth-only rotator (judged on
        azimuth, as in the prediction)."""
        return ("pointing error" if self._spec is None or self._spec.has_elevation
                else "azimuth error")

    def _measure(self, t_s: float, wire_az_deg: float, el_deg: float | None) -> None:
        """The pointing error of a read-back (wire degrees) at ``t_s``, while the pass runs
        (the slew before T and the park after are not the pass's error)."""
        self._last_error_deg = None
        if self._sky is None or self._spec is None or wire_az_deg < 0 or \
                not self._pass_s[0] <= t_s <= self._pass_s[1]:
            if self.on_reading is not None and wire_az_deg >= 0:
                self.on_reading(t_s, wire_az_deg, el_deg, None)
            return
        # Every mechanical candidate of a wire azimuth has the same bearing: no belief needed.
        m_az = self._spec.frame.nearest_mech_of_wire(wire_az_deg)
        taz, tel = self._sky.direction_at(t_s)
        err = float(pointing_error_deg(self._spec, m_az, el_deg, (float(taz), float(tel))))
        self._last_error_deg = err
        self.report.errors_deg.append(err)
        if self.on_reading is not None:
            self.on_reading(t_s, wire_az_deg, el_deg, err)

    # Helpers ------------------------------------------------------------------------------

    def _wait_until(self, t_s: float, what: str = "") -> None:
        """Wait for ``t_s``; a wait for ``what`` longer than a progress period says how long
        is left, every :data:`PROGRESS_S` (each minute while more than two are left)."""
        said = -float("inf")
        # Sleep in slices so a Ctrl-C lands promptly even with a long wait before AOS.
        while True:
            now = self.clock.timestamp()
            left = t_s - now
            if left <= 0:
                return
            every = PROGRESS_LONG_S if left > 2 * PROGRESS_LONG_S else PROGRESS_S
            if what and left > PROGRESS_S and now - said >= every:
                said = now
                self.progress(f"waiting for {what}: {_mmss(left)} to go")
            self.clock.sleep(min(left, 1.0))

    def _all_stop(self, quiet: bool) -> None:
        try:
            self.driver.stop()
            self.report.stopped = True
            self.log("all-stop sent")
        except TrackerError:
            if not quiet:
                raise


def _mmss(seconds: float) -> str:
    """``1:05:03`` / ``4:07``."""
    m, sec = divmod(max(0, round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


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
        raise with_advice(ConfigError, "the pass in this plan is over; nothing left to send",
                          f". Plan the next pass ({MAKE_PLAN})")
    return out


