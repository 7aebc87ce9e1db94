"""Following passes: one antenna pass after pass, the demo's simulated time, two antennas on one
GS-232B-AZ/AZ port.

:class:`PassFollower` tracks ``N`` passes of one target in a row (0: until stopped) on a driver
(a connect callable behind a :class:`~tracker.stream.Link`): it plans inside the controller's
effective limits once (:class:`~tracker.session.EffectiveLimits`), then for every pass reads
the antenna's real position back, plans from there (:func:`~tracker.planner.plan_pass`), runs
the live loop (:func:`~tracker.stream.run_pass`) and looks up the next pass. Every step is
reported to an event sink (``events(kind, **data)``, ``on_status(Status)``: what
:mod:`tracker.trackui` shows and logs). :func:`follow_passes` does the same inside a
:class:`~tracker.session.ControllerSession` (all-stop on every exit) for a library user.

:class:`DemoTime` is the demo's time policy on a :class:`~tracker.clock.SimClock`: paused while
an antenna plans, idle stretches before a pass skipped when every antenna waits;
:func:`demo_start` replays a pass near the epoch of stale elements and :func:`demo_speed`
picks a speed that shows a pass in about a minute.

:class:`SharedAzAz` is one GS-232B-AZ/AZ interface shared by two antennas' followers (one
axis each, ``S`` for both); :func:`follow_together` runs them at once, one thread each: a
stall, an error or Ctrl-C on either stops both.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from datetime import datetime, timedelta, timezone
from typing import TYPE_CHECKING, Any

import numpy as np

from tracker.clock import Clock, SimClock
from tracker.errors import ConfigError, TargetError, TrackerError
from tracker.stream import EventSink, Link, PassResult, Status, StreamSettings, close_quietly

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.mount import RotatorSpec
    from tracker.passes import Pass
    from tracker.session import EffectiveLimits
    from tracker.station import Station
    from tracker.targets import Target

PASS_SEARCH_DAYS = 3.0
PAD_S = 60.0                # the sky track runs this long before AOS and after LOS
DEMO_SECONDS = 60.0         # a whole demo pass in about this much wall time
DEMO_LEAD_S = 150.0         # the demo's clock starts this long before the first AOS
STALE_ELEMENTS_DAYS = 14.0  # older elements: the demo replays a pass near their epoch
IDLE_SKIP_MIN_S = 30.0      # the demo skips idle stretches longer than this
JOIN_TIMEOUT_S = 10.0       # an antenna loop notices a stop within a cycle or a read timeout


def _null_sink(kind: str, **data: Any) -> None:
    return None


def _no_status(st: Status) -> None:
    return None


def _never() -> bool:
    return False


# Passes ---------------------------------------------------------------------------------------


def next_pass(target: Target, station: Station, after_s: float,
              search_days: float = PASS_SEARCH_DAYS) -> Pass:
    """The first pass of ``target`` over ``station`` that ends more than 30 s after POSIX
    ``after_s`` (a target that never sets has none); :class:`TargetError` if there is none
    within ``search_days``."""
    from tracker.passes import find_passes

    start = datetime.fromtimestamp(after_s, timezone.utc)
    passes = find_passes(target, station, start, start + timedelta(days=search_days))
    passes = [p for p in passes if p.los.timestamp() > after_s + 30 and not p.always_up]
    if not passes:
        raise TargetError(f"{target.name} has no pass over {station.name} in the "
                          f"{search_days:g} days after {start:%Y-%m-%d %H:%M} UTC")
    return passes[0]


def describe_mode(mode: str, reason: str) -> str:
    """``mode normal: the pass stays ...``: the planner's reason names its mode first
    (``Normal: ...``); say it once."""
    head = f"{mode.capitalize()}: "
    if reason.startswith(head):
        reason = reason[len(head):]
    return f"mode {mode}: {reason}"


def describe_result(res: PassResult, spec: RotatorSpec) -> str:
    """``20 commands, max pointing error 3.8 deg, 0 reconnects``; an azimuth-only rotator
    is judged on azimuth, and says so."""
    what = "pointing" if spec.has_elevation else "azimuth"
    return (f"{res.commands} commands, max {what} error {res.max_error_deg:.1f} deg, "
            f"{res.reconnects} reconnects")


class SkyAt:
    """Where ``target`` is at one time, for a status outside the planned track (waiting for
    the pass): observed in chunks of ``chunk_s`` at ``step_s`` and interpolated, so a status
    every cycle costs no ephemeris call."""

    def __init__(self, target: Target, station: Station, chunk_s: float = 600.0,
                 step_s: float = 5.0):
        self.target, self.station = target, station
        self.chunk_s, self.step_s = chunk_s, step_s
        self._track: Any = None

    def __call__(self, t_s: float) -> tuple[float, float]:
        tr = self._track
        if tr is None or not (tr.t_s[0] <= t_s <= tr.t_s[-1]):
            ts = np.arange(t_s, t_s + self.chunk_s + self.step_s, self.step_s)
            tr = self._track = self.target.observe(self.station, ts)
        az, el = tr.direction_at(t_s)
        return float(az), float(el)


def describe_pass(p: Pass) -> str:
    """``2026-08-23 02:07:45 UTC, max el 34 deg, 9.3 min``."""
    return (f"{p.aos:%Y-%m-%d %H:%M:%S} UTC, max el {p.max_el_deg:.0f} deg, "
            f"{p.duration_s / 60:.1f} min")


# The demo's simulated time ---------------------------------------------------------------------


def demo_start(target: Target, now: datetime,
               stale_days: float = STALE_ELEMENTS_DAYS) -> tuple[datetime, str]:
    """Where a demo's search for the next pass starts: ``now``, or the epoch of elements
    older than ``stale_days`` (their passes that far out are fiction), with a note saying so
    ("" when ``now`` is kept)."""
    elements = getattr(target, "elements", None)
    epoch = getattr(elements, "epoch", None)
    if epoch is not None:
        age = (now - epoch).total_seconds() / 86400.0
        if age > stale_days:
            return epoch, (f"the elements for {target.name} are {age:.0f} days old (epoch "
                           f"{epoch:%Y-%m-%d %H:%M} UTC): the simulation replays a pass just "
                           f"after their epoch. `tracker tle update` fetches current ones.")
    return now, ""


def demo_clock_start(first_passes: Sequence[Pass], start: datetime) -> datetime:
    """A demo's clock starts shortly before the earliest of the first passes (not before
    ``start``)."""
    earliest = min(p.aos for p in first_passes)
    return max(start, earliest - timedelta(seconds=DEMO_LEAD_S))


def demo_speed(first_passes: Sequence[Pass], start: datetime,
               wall_s: float = DEMO_SECONDS) -> float:
    """A speed at which the longest of the first passes (from its pre-position, at most
    2 min before AOS) shows in about ``wall_s`` of wall time; never below real time."""
    span = max(p.los.timestamp() - max(p.aos.timestamp() - 120.0, start.timestamp())
               for p in first_passes)
    return max(1.0, round(span / wall_s))


class DemoTime:
    """Simulated time of the demo, shared by its antennas: paused while any of them plans
    (pass searches are slow at a high speed), and idle stretches before a pass skipped only
    when every antenna still tracking is waiting for its next pass.

    ``antennas``: the numbers of the followers (:attr:`PassFollower.antenna`) sharing it; each
    first plans with the clock paused."""

    def __init__(self, clock: SimClock, antennas: Sequence[int]):
        self.clock = clock
        self._cv = threading.Condition()
        self._holders = set(antennas)     # each antenna first plans with the clock paused
        self._active = set(antennas)
        self._idle: dict[int, float] = {}
        clock.pause()

    def _apply(self) -> None:
        if self._holders:
            self.clock.pause()
        else:
            self.clock.resume()

    def hold(self, n: int) -> None:
        """Antenna ``n`` plans: time stands still."""
        with self._cv:
            self._holders.add(n)
            self._apply()

    def release(self, n: int) -> None:
        """Antenna ``n`` is done planning."""
        with self._cv:
            self._holders.discard(n)
            self._apply()
            self._cv.notify_all()

    def leave(self, n: int) -> None:
        """Antenna ``n`` tracks no more: the others no longer wait for it."""
        with self._cv:
            self._holders.discard(n)
            self._active.discard(n)
            self._idle.pop(n, None)
            self._apply()
            self._cv.notify_all()

    def idle_until(self, n: int, t_s: float, say: Callable[[str], None],
                   should_stop: Callable[[], bool]) -> None:
        """Wait until simulated ``t_s``; skip ahead when every active antenna is idle."""
        with self._cv:
            self._idle[n] = t_s
            try:
                while not should_stop():
                    now = self.clock.timestamp()
                    if now >= t_s:
                        return
                    if self._active <= set(self._idle) and not self._holders:
                        gap = min(self._idle.values()) - now
                        if gap > IDLE_SKIP_MIN_S:
                            say(f"skipping {gap / 60:.0f} min of simulated idle time to the "
                                f"next pass")
                            self.clock.skip(gap)
                            self._cv.notify_all()
                            continue
                    self._cv.wait(timeout=min(0.2, max(0.01, (t_s - now) / self.clock.speed)))
            finally:
                self._idle.pop(n, None)


# One antenna, pass after pass -------------------------------------------------------------------


class PassFollower:
    """One antenna following one target pass after pass.

    ``connect`` opens the driver (again after a lost port); ``spec`` is the rotator;
    ``settings`` tune the live loop (``park_after_pass`` among them); ``events`` and
    ``on_status`` receive what :func:`~tracker.stream.run_pass` reports plus the plan of each
    pass (``info`` lines, ``state`` ``plan`` / ``pass_done`` records). ``antenna``: 1 or 2 for
    the antennas of a two-antenna run, 0 for a single one. ``first``: the first pass to track
    (default: the next one after the clock's time). ``demo_time``: the demo's time policy, if
    any. ``on_next_pass`` hears, once each pass is planned, the pass after it (None if none in
    the search window), e.g. for a panel that shows it.

    :meth:`run` tracks; :attr:`results` holds a :class:`~tracker.stream.PassResult` per
    completed pass. :meth:`stop` is the all-stop for a session, :meth:`close` drops the port.
    """

    def __init__(self, target: Target, connect: Callable[[], Any], spec: RotatorSpec,
                 station: Station, clock: Clock, settings: StreamSettings | None = None, *,
                 events: EventSink = _null_sink,
                 on_status: Callable[[Status], None] = _no_status,
                 antenna: int = 0, first: Pass | None = None,
                 demo_time: DemoTime | None = None,
                 on_next_pass: Callable[[Pass | None], None] | None = None):
        self.target = target
        self.spec = spec
        self.station = station
        self.clock = clock
        self.settings = settings if settings is not None else StreamSettings()
        self.events = events
        self.on_status = on_status
        self.antenna = antenna
        self.first = first
        self.demo_time = demo_time
        self.on_next_pass = on_next_pass
        self.link = Link(connect, spec)
        self.results: list[PassResult] = []
        self.limits: EffectiveLimits | None = None

    @property
    def label(self) -> str:
        """``ant1 ISS (ZARYA)`` for an antenna of a two-antenna run, else ""."""
        return f"ant{self.antenna} {self.target.name}" if self.antenna else ""

    def plan_inside_the_controller(self) -> EffectiveLimits:
        """Effective limits, once, before planning: the rotator spec narrowed by what the
        connected controller accepts (rotctld's limits, a 360 deg mode), so every pass is
        planned inside them instead of failing on a move the controller refuses."""
        from tracker.session import EffectiveLimits

        if self.limits is not None:
            return self.limits
        driver: Any = self.link.ensure()
        limits = EffectiveLimits.of(self.spec, self.station, driver.capabilities)
        spec = limits.rotator()
        if spec != self.spec:
            self.events("info", text=f"planning inside the controller's limits: "
                                     f"{limits.describe()}")
            self.spec = self.link.spec = spec
        self.limits = limits
        return limits

    def run(self, passes: int = 1, should_stop: Callable[[], bool] = _never
            ) -> list[PassResult]:
        """Track ``passes`` passes in a row (0: until stopped, or no next pass in the search
        window), re-planning each from the real antenna position; returns :attr:`results`.
        A pass cut short (``should_stop``) ends the run without a result for it; errors of
        the loop (:class:`~tracker.errors.StallError`, a lost port given up ...) propagate
        after its all-stop."""
        from tracker.planner import error_cause, plan_pass
        from tracker.stream import TrackCore, run_pass

        if passes < 0:
            raise ConfigError(f"passes {passes} is invalid; use 1 or more, or 0 for "
                              f"'until stopped'")
        self.plan_inside_the_controller()
        link, out, settings, target = self.link, self.events, self.settings, self.target
        station, timer = self.station, self.demo_time
        n = 0
        pas = self.first if self.first is not None else next_pass(
            target, station, self.clock.timestamp())
        while (passes == 0 or n < passes) and not should_stop():
            # Re-plan from the real antenna position (read back now, not assumed).
            link.events = out
            az, el = link.position()
            if timer is not None:
                timer.hold(self.antenna)
            try:
                spec = self.spec
                current = _mech_guess(spec, az, el)
                track = pas.track(step_s=1.0, pad_s=PAD_S)
                plan = plan_pass(track, spec, station, current=current,
                                 park=settings.park_after_pass)
                try:
                    nxt: Pass | None = next_pass(target, station, pas.los.timestamp() + 60.0)
                except TargetError:
                    nxt = None
            finally:
                if timer is not None:
                    timer.release(self.antenna)
            if self.on_next_pass is not None:
                self.on_next_pass(nxt)
            out("info", topic="plan", text=f"pass {n + 1}: {target.name} "
                                           f"{describe_pass(pas)}; "
                                           f"{describe_mode(plan.mode, plan.reason)}")
            out("state", state="plan", mode=plan.mode,
                predicted_max_error_deg=round(plan.max_error_deg, 2),
                aos=pas.aos.isoformat(), los=pas.los.isoformat())
            if timer is not None:
                lead = min(plan.preposition_t_s, pas.aos.timestamp() - 120.0) - 10.0
                timer.idle_until(self.antenna, lead, lambda text: out("info", text=text),
                                 should_stop)
            core = TrackCore(plan, track, spec, station, settings,
                             sky=SkyAt(target, station))
            joined_s = self.clock.timestamp()
            res = run_pass(core, link, self.clock, on_status=self.on_status, events=out,
                           should_stop=should_stop)
            if not res.completed:
                break                                   # stopped: the caller says why
            res.count_from_acquisition(joined_s - pas.aos.timestamp(), settings.deadband_deg)
            err = res.errors_deg[res.acquired_at:]
            p99 = sorted(err)[max(0, math.ceil(0.99 * len(err)) - 1)] if err else float("nan")
            res.cause = "; ".join(x for x in (res.joined_note(), error_cause(
                track, spec, plan.mode, np.asarray(res.error_t_s[res.acquired_at:]),
                np.asarray(err))) if x)
            self.results.append(res)
            out("info", topic="result", text=f"pass {n + 1} done: "
                                             f"{describe_result(res, spec)} (plan predicted "
                                             f"{plan.max_error_deg:.1f} + deadband "
                                             f"{settings.deadband_deg:g})")
            if res.cause:
                out("info", topic="cause", text=res.cause)
            out("state", state="pass_done", commands=res.commands,
                max_error_deg=round(res.max_error_deg, 2), p99_error_deg=round(p99, 2),
                reconnects=res.reconnects)
            n += 1
            if nxt is None:
                break
            pas = nxt
        return self.results

    def stop(self) -> bool:
        """All-stop; True if it reached the controller."""
        return self.link.stop()

    def close(self) -> None:
        """Release the port."""
        self.link.drop()


def follow_passes(target: Target, connect: Callable[[], Any], spec: RotatorSpec,
                  station: Station, clock: Clock, settings: StreamSettings | None = None, *,
                  passes: int = 1, first: Pass | None = None,
                  events: EventSink = _null_sink,
                  on_status: Callable[[Status], None] = _no_status) -> list[PassResult]:
    """Track ``passes`` passes of ``target`` in a row (0: until Ctrl-C) with the rotator
    ``spec`` on the driver ``connect`` opens, inside a
    :class:`~tracker.session.ControllerSession`: SIGINT/SIGTERM/SIGHUP end it like Ctrl-C, and
    every way out but a normal end sends all-stop last. Returns one result per completed pass.
    See :class:`PassFollower` for the arguments."""
    from tracker.session import ControllerSession

    follower = PassFollower(target, connect, spec, station, clock, settings, events=events,
                            on_status=on_status, first=first)
    try:
        with ControllerSession(follower.stop, stop_at_end=False):
            return follower.run(passes)
    finally:
        follower.close()


def _mech_guess(spec: RotatorSpec, wire_az: float, wire_el: float | None
                ) -> tuple[float, float]:
    """The antenna's mechanical position from a read-back with no history: trust the
    controller's own scale (a 450 deg controller reports 0-450)."""
    if wire_az < 0:
        raise ConfigError("the controller reports no position (AZ=-001: control box off?); "
                          "switch the rotator's control box on and retry")
    m = spec.frame.nearest_mech_of_wire(wire_az)
    return (m, float(wire_el) if wire_el is not None else 0.0)


# Two antennas on one GS-232B-AZ/AZ port -----------------------------------------------------------


class SharedAzAz:
    """One GS-232B-AZ/AZ interface shared by both antennas' loops: opened once, reopened
    once (under a lock) after the port was lost, ``S`` (all-stop) for both. Its driver
    serialises requests itself (:class:`Gs232Driver` holds a lock per request).

    ``open_fn`` opens the AZ/AZ driver; ``axis(n)`` is antenna ``n``'s connect callable for
    its :class:`PassFollower` (``functools.partial(shared.axis, n)``)."""

    def __init__(self, open_fn: Callable[[], Any]):
        self._open = open_fn
        self._lock = threading.Lock()
        self._drv: Any = None
        self._gen = 0
        self.finished = False     # the run's final S went out: nothing may move after it

    def final_stop(self) -> bool:
        """The run's last word, ``S``; a loop that outlives the join can only stop after it."""
        self.finished = True
        return self.all_stop()

    def axis(self, n: int) -> AxisLease:
        with self._lock:
            if self._drv is None:
                self._drv = self._open()
                self._gen += 1
            return AxisLease(self, self._drv.axis(n), self._gen)

    def lost(self, gen: int) -> None:
        """A loop lost the port of generation ``gen``: close it (once), so the next
        ``axis()`` reopens; a loop still on an older generation changes nothing."""
        with self._lock:
            if gen == self._gen:
                self._close()

    def _close(self) -> None:
        drv, self._drv = self._drv, None
        close_quietly(drv)

    def all_stop(self) -> bool:
        """``S``: both antennas; True if it reached the controller."""
        with self._lock:
            try:
                if self._drv is None:
                    self._drv = self._open()
                    self._gen += 1
                self._drv.stop()
                return True
            except (TrackerError, OSError):
                self._close()
                return False

    def session_stop(self, events: EventSink = _null_sink) -> bool:
        """A session's all-stop (:class:`~tracker.session.ControllerSession`): the final
        ``S``; a failure is reported to ``events`` here, never raised."""
        if self.final_stop():
            return True
        events("state", state="stop_failed", reason="all-stop S did not reach the "
                                                    "controller")
        return False

    def close(self) -> None:
        with self._lock:
            self._close()


class AxisLease:
    """One antenna's view of the shared interface, as a :class:`Link` driver: closing it
    (what the loop does when the port is lost) reports the loss instead of closing the
    port under the other antenna."""

    def __init__(self, shared: SharedAzAz, axis: Any, gen: int):
        self.shared, self.axis, self.gen = shared, axis, gen
        self.capabilities = axis.capabilities

    def position(self) -> tuple[float, float | None]:
        return self.axis.position()

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        if self.shared.finished:
            raise TrackerError("the run has ended (all-stop sent); no further moves")
        self.axis.goto(az_deg)

    def stop(self) -> None:
        if self.shared.finished:
            # A loop slower than the join: its A / E would land after the run's S.
            self.shared.all_stop()
            return
        self.axis.stop()      # A / E: this antenna only; the run's all-stop is S

    def close(self) -> None:
        self.shared.lost(self.gen)


def follow_together(followers: Sequence[PassFollower], shared: SharedAzAz,
                    passes: int = 1, events: EventSink = _null_sink) -> None:
    """Both antennas at once, one thread each on the shared interface. A stall, an error or
    Ctrl-C/SIGTERM on either stops both (``S``) and ends the run; every way out ends
    with ``S``. ``events`` gets the run-wide records (the final ``S``); each follower reports
    to its own sink. An error of an antenna is raised as a :class:`TrackerError` that names
    it (a non-tracker exception as itself)."""
    stop = threading.Event()
    failures: list[tuple[PassFollower, BaseException]] = []

    def work(a: PassFollower) -> None:
        try:
            a.link.events = a.events     # each antenna reports its own first connection
            a.run(passes, should_stop=stop.is_set)
        except BaseException as e:   # any end of a loop ends both; the main thread reports
            failures.append((a, e))
            stop.set()
            shared.all_stop()        # at once: the other loop notices within a cycle
        finally:
            if a.demo_time is not None:
                a.demo_time.leave(a.antenna)
            leave = getattr(a.clock, "leave", None)
            if leave is not None:    # virtual time: the other loop no longer waits for this one
                leave()

    threads = [threading.Thread(target=work, args=(a,), name=f"track-ant{a.antenna}",
                                daemon=True) for a in followers]
    try:
        for t in threads:
            t.start()
        while any(t.is_alive() for t in threads):
            for t in threads:
                t.join(timeout=0.2)   # short joins: Ctrl-C/SIGTERM reach this thread
    except KeyboardInterrupt:
        stop.set()
        shared.all_stop()
        events("info", text="interrupted: all-stop (S) sent to both antennas")
        raise
    finally:
        stop.set()
        for t in threads:
            t.join(timeout=JOIN_TIMEOUT_S)
        # Last word on the wire: S, after both loops sent their own A / E.
        if shared.final_stop():
            events("command", cmd="stop", note="S: both antennas")
        else:
            events("state", state="stop_failed", reason="all-stop S did not reach the "
                                                        "controller")
    if failures:
        _raise_failure(*failures[0])


def _raise_failure(a: PassFollower, e: BaseException) -> None:
    """The first error of an antenna, naming it."""
    if not isinstance(e, TrackerError):
        raise e                  # a bug, not a rotator problem: keep its traceback
    raise TrackerError(f"antenna {a.antenna} ({a.target.name}): {e}; all-stop (S) sent, "
                       f"both antennas stopped") from e
