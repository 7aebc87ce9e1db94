"""The station service: the rolling schedule executed pass after pass, unattended.

:class:`StationService` keeps a schedule of the next ``horizon_h`` hours
(:func:`tracker.service.plan.build_rolling_schedule`), refreshes elements on its own
(:class:`tracker.service.elements.ElementKeeper`), and runs each chosen pass with the live loop
(:class:`tracker.tracking.PassFollower`) or as an uploaded step table
(:class:`tracker.upload.TableRunner`), parking in between. Everything it does is on the
injected clock, so a simulated day runs on virtual time.

What a station meets, and what the service does:

- **The controller unplugged or power-cycled.** The live loop reconnects within a pass; a
  pass whose port never comes back ends ``failed`` with the reason, and the next pass opens
  the port afresh. A stall ends the pass with all-stop (the loop sends it) and ``failed``.
- **A pass that cannot be followed** (it ended while the controller was gone, or the clock
  jumped past it) is ``skipped`` with the reason; nothing is commanded for it.
- **The network gone.** Element refresh failures are faults on the board; the service keeps
  going on the cached elements and says how old they are.
- **The clock jumping.** Backwards or forwards by more than :data:`CLOCK_JUMP_S`, the
  schedule is recomputed from the new time.
- **A restart.** The outcome of every pass is kept in a small state file, written
  atomically; a restarted service neither tracks a done pass again nor forgets a skip.

The service itself never commands a position: every move is made by the live loop or the
step table, inside the effective limits and above the mask. The caller runs :meth:`run` inside
a :class:`~tracker.session.ControllerSession` (all-stop on every way out).
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tracker.errors import ConfigError, TrackerError
from tracker.service.board import StatusBoard
from tracker.service.records import PassLog, StationState
from tracker.timescale import iso_utc

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.clock import Clock
    from tracker.config import ScheduleSettings
    from tracker.controllers import Controller
    from tracker.mount import RotatorSpec
    from tracker.service.elements import ElementKeeper
    from tracker.service.plan import PlannedPass, RollingSchedule
    from tracker.station import Station
    from tracker.stream import PassResult, Status, StreamSettings

# The longest single wait: the loop looks at stop requests, reloads and refreshes this often.
NAP_S = 60.0
# Recompute the schedule this often even without new elements (its horizon rolls on).
REPLAN_S = 3600.0
# A clock that moved this much more (or less) than the service slept has jumped.
CLOCK_JUMP_S = 120.0
# How long before AOS the pass is handed to the loop, beyond the slew: the loop pre-positions
# itself, and a step table needs its upload time.
LEAD_S = 120.0
# Passes this long over are no longer kept from one schedule to the next.
KEEP_S = 6 * 3600.0
# A read-back that has not moved for this long: the motors have stopped (a motor start is
# movement after it).
STILL_S = 3.0
# A park must end this long before the next pass is handed to the loop.
PARK_MARGIN_S = 60.0
# Interval of the sky path the status page draws for the current pass.
PATH_STEP_S = 10.0


def _never() -> bool:
    return False


@dataclass
class PassOutcome:
    """What became of one scheduled pass (one line of the pass log)."""

    key: str
    target: str
    aos_utc: str
    los_utc: str
    mode: str
    outcome: str                       # done | skipped | failed
    reason: str = ""
    chosen: bool = True                # False: the schedule did not choose it (reason says why)
    max_el_deg: float = math.nan
    predicted_max_error_deg: float | None = None
    measured_max_error_deg: float | None = None
    commands: int = 0
    starts: int = 0
    travel_deg: float = 0.0
    reconnects: int = 0
    faults: list[str] = field(default_factory=list)
    pass_: Any = field(default=None, repr=False, compare=False)   # the Pass, for plots

    def record(self) -> dict[str, Any]:
        out = dict(self.__dict__)
        out.pop("pass_")
        for k in ("max_el_deg", "predicted_max_error_deg", "measured_max_error_deg",
                  "travel_deg"):
            v = out[k]
            out[k] = None if v is None or not math.isfinite(v) else round(float(v), 2)
        return out


@dataclass
class StationReport:
    """The run's figures: what was scheduled, tracked, skipped (why) and how well."""

    started_utc: str
    ended_utc: str
    outcomes: list[PassOutcome] = field(default_factory=list)
    faults: list[str] = field(default_factory=list)

    def plot(self, path: str | Path, start_s: float, end_s: float, *, force: bool = False,
             label: str = "") -> Path:
        """The run as a timeline (the ``[plot]`` extra): every pass of the targets, the
        tracked ones solid, the rest hollow."""
        from tracker.export import pass_records
        from tracker.plot import timeline_plot

        shown = [o for o in self.outcomes if o.pass_ is not None]
        tracked = {i for i, o in enumerate(shown) if o.outcome == "done"}
        return timeline_plot(pass_records([o.pass_ for o in shown]), path, start_s, end_s,
                             title=f"station run {self.started_utc} .. {self.ended_utc}: "
                                   f"{len(tracked)} passes tracked (solid)",
                             chosen=tracked, force=force, label=label)

    def count(self, outcome: str, chosen: bool = True) -> int:
        return sum(1 for o in self.outcomes if o.outcome == outcome and o.chosen == chosen)

    def text(self) -> str:
        """The report printed at the end of a run (and of a simulated day)."""
        done = [o for o in self.outcomes if o.outcome == "done"]
        chosen = [o for o in self.outcomes if o.chosen]
        lines = [f"station report {self.started_utc} .. {self.ended_utc}",
                 f"passes: {len(chosen)} scheduled, {len(done)} tracked, "
                 f"{self.count('skipped')} skipped, {self.count('failed')} failed; "
                 f"{len(self.outcomes) - len(chosen)} other passes of the targets not "
                 f"scheduled"]
        why = Counter(_reason_kind(o) for o in self.outcomes if o.outcome != "done")
        for reason, n in sorted(why.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  {n} x {reason}")
        if done:
            lines.append(f"{'target':<22} {'AOS (UTC)':<17} {'mode':<6} {'max el':>6} "
                         f"{'planned':>7} {'measured':>8} {'cmds':>5} {'starts':>6} "
                         f"{'travel':>7}")
            for o in done:
                lines.append(
                    f"{o.target[:22]:<22} {o.aos_utc[:16].replace('T', ' '):<17} "
                    f"{o.mode:<6} {_deg(o.max_el_deg):>6} "
                    f"{_deg(o.predicted_max_error_deg):>7} "
                    f"{_deg(o.measured_max_error_deg):>8} {o.commands:>5} {o.starts:>6} "
                    f"{_deg(o.travel_deg, 0):>7}")
            measured = [o.measured_max_error_deg for o in done
                        if o.measured_max_error_deg is not None]
            planned = [o.predicted_max_error_deg for o in done
                       if o.predicted_max_error_deg is not None]
            lines.append(
                f"max error: planned worst {_deg(max(planned, default=None))} deg, measured "
                f"worst {_deg(max(measured, default=None))} deg; motor starts "
                f"{sum(o.starts for o in done)}, commands {sum(o.commands for o in done)}, "
                f"travel {sum(o.travel_deg for o in done):.0f} deg")
        if self.faults:
            lines.append(f"faults: {len(self.faults)} (last: {self.faults[-1]})")
        return "\n".join(lines)


def _reason_kind(o: PassOutcome) -> str:
    """A reason with its pass's own numbers taken out, so the report can count alike ones."""
    low = re.match(r"max el [\d.]+ < ([\d.]+)", o.reason)
    if low:
        return f"not scheduled: max el below {low[1]} deg"
    head = o.reason.split(":")[0] if o.outcome != "skipped" or o.chosen else o.reason
    return f"{'not scheduled' if not o.chosen else o.outcome}: {head}"


def _why_none(sched: RollingSchedule) -> str:
    """Why a schedule holds no pass, for the line that says so."""
    if not sched.skipped:
        return (": no pass in the schedule (no target rises and sets then: never above the "
                "horizon, or always up like a geostationary satellite)")
    first = sched.skipped[0]
    return (f": no pass in the schedule ({len(sched.skipped)} pass(es) of the targets left "
            f"out, e.g. {first.target.name}: {first.reason})")


def _deg(v: float | None, nd: int = 1) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.{nd}f}"


class _CutShort(Exception):
    """The live loop stopped because the service was asked to stop."""


class _PassWatch:
    """What one pass's loop or table runner reports: onto the board through a
    :class:`~tracker.service.board.BoardFeed`, into the pass's figures (motor starts and
    travel from the read-back, the faults) and, for info lines and faults, to the log."""

    def __init__(self, board: StatusBoard, spec: RotatorSpec, target: str, sky: Any,
                 say: Callable[[str], None]):
        from tracker.service.board import BoardFeed

        self.feed = BoardFeed(board, spec, target=target)
        self.board = board
        self.spec = spec
        self.target = target
        self.sky = sky
        self.say = say
        self.faults: list[str] = []
        self.starts = 0
        self.travel_deg = 0.0
        self._last: tuple[float, float] | None = None
        self._moved_t_s = 0.0
        self._moving = False
        self._detail_state = "uploading"

    def _seen(self, t_s: float, az_m_deg: float, el_deg: float | None) -> None:
        """A read-back (mechanical azimuth). Travel is counted between readings more than
        the read-back's rounding apart (a slow axis moves less than that per reading); a
        motor start is movement after :data:`STILL_S` without any."""
        now = (float(az_m_deg), float(el_deg or 0.0))
        if self._last is None:
            self._last, self._moved_t_s = now, t_s
            return
        step = abs(now[0] - self._last[0]) + abs(now[1] - self._last[1])
        if step > 1.5 * self.spec.resolution_deg:
            self.travel_deg += step
            if not self._moving:
                self.starts += 1
            self._moving, self._last, self._moved_t_s = True, now, t_s
        elif t_s - self._moved_t_s > STILL_S:
            self._moving = False

    def status(self, st: Status) -> None:
        """The live loop's cycle."""
        self.feed.status(st)
        if st.antenna_az_m_deg is not None:
            self._seen(st.t_s, st.antenna_az_m_deg, st.antenna_el_deg)

    def reading(self, t_s: float, wire_az_deg: float, el_deg: float | None,
                error_deg: float | None) -> None:
        """A step table's read-back."""
        frame = self.spec.frame
        az_m = float(frame.nearest_mech_of_wire(wire_az_deg))
        taz, tel = self.sky.direction_at(t_s)
        self.feed.position(float(frame.bearing_of(az_m)), el_deg, float(taz), float(tel),
                           error_deg)
        self._detail_state = "tracking"
        self._seen(t_s, az_m, el_deg)

    def progress(self, text: str) -> None:
        self.board.set_state(self._detail_state, f"{self.target}: {text}")

    def event(self, kind: str, **data: Any) -> None:
        from tracker.service.board import FAULT_EVENTS
        from tracker.trackui import describe_state

        self.feed.event(kind, **data)
        if kind == "info" and data.get("text"):
            self.say(str(data["text"]))
        elif kind == "state" and data.get("state") in FAULT_EVENTS:
            text = describe_state(data) or str(data.get("state"))
            self.faults.append(text)
            self.say(f"fault: {text}")


class StationService:
    """Runs a station: see the module docstring.

    ``connect`` opens the controller's driver (afresh for each pass, so the port is free
    between passes); ``controller`` is its registry entry; ``keeper`` refreshes and serves
    the elements (None: the catalogue ``catalog`` given, never refreshed, as in a
    simulation); ``state_path`` and ``pass_log`` keep outcomes across restarts and as JSON
    lines; ``say`` gets one plain line per event (journald-friendly); ``control`` (a
    :class:`~tracker.service.rotctld_server.RotctldServer`) is handed the rotator between
    passes and taken back before each.
    """

    def __init__(self, *, station: Station, spec: RotatorSpec, controller: Controller,
                 connect: Callable[[], Any], clock: Clock, schedule: ScheduleSettings,
                 stream: StreamSettings, board: StatusBoard,
                 keeper: ElementKeeper | None = None, catalog: Any = None,
                 state_path: str | Path | None = None, pass_log: PassLog | None = None,
                 say: Callable[[str], None] = lambda _text: None, control: Any = None,
                 table_interval_s: int | None = None):
        if keeper is None and catalog is None:
            raise ConfigError("a station needs elements: an element keeper or a catalogue")
        self.station = station
        self.spec = spec
        self.controller = controller
        self.connect = connect
        self.clock = clock
        self.settings = schedule
        self.stream = stream
        self.board = board
        self.keeper = keeper
        if keeper is not None:
            keeper.events = self._element_event
        self._catalog = catalog
        self.state_path = Path(state_path).expanduser() if state_path else None
        self.pass_log = pass_log
        self._say = say
        self.control = control
        self.table_interval_s = table_interval_s
        self.schedule: RollingSchedule | None = None
        self.state = StationState()
        self.report = StationReport(iso_utc(clock.now()), iso_utc(clock.now()))
        self._logged: set[tuple[str, bool]] = set()
        self._reload: Callable[[], None] | None = None
        self._reload_wanted = False
        self._active: Any = None          # the pass's follower or driver, for all-stop
        self._should_stop: Callable[[], bool] = _never

    # -- small parts ---------------------------------------------------------------------
    def say(self, text: str) -> None:
        self._say(f"{iso_utc(self.clock.now())} {text}")

    def fault(self, text: str) -> None:
        self.report.faults.append(text)
        self.board.add_fault(text)
        self.say(f"fault: {text}")

    def _element_event(self, kind: str, **data: Any) -> None:
        text = str(data.get("text", ""))
        if kind == "fault":
            self.fault(text)
        else:
            self.say(text)

    def request_reload(self, reload: Callable[[], None]) -> None:
        """Ask for ``reload`` (re-read the configuration) at the next safe moment: between
        passes, never during one. Safe to call from a signal handler."""
        self._reload, self._reload_wanted = reload, True

    def all_stop(self) -> bool:
        """All-stop on the rotator, whoever holds it: the pass under way, an outside client
        of the control port, or nobody (then the port is opened for it). True if it reached
        the controller."""
        active = self._active
        if active is not None:
            return active.stop() is not False
        if self.control is not None:
            self.control.take_back("the station is stopping")
        driver = self.connect()
        try:
            driver.stop()
        finally:
            driver.close()
        return True

    def catalog(self) -> Any:
        return self.keeper.catalog() if self.keeper is not None else self._catalog

    # -- schedule --------------------------------------------------------------------------
    def replan(self, why: str, *, strict: bool = False) -> None:
        """Recompute the schedule from now. A failure is a fault and the old schedule stays;
        with ``strict`` it is raised instead (the first schedule of a run, a reload: a name
        the catalogue does not know must stop the run or the reload, not fault forever)."""
        from tracker.service.plan import build_rolling_schedule

        now_s = self.clock.timestamp()
        self._skip_missed(now_s)      # before they drop out of the new schedule unsaid
        # Passes of the last schedule: the done and failed stay as they were, the planned
        # lend their stream/table decision (no table compiled again); long over, dropped.
        keep = [p for p in (self.schedule.chosen if self.schedule else ())
                if p.pass_.los.timestamp() > now_s - KEEP_S]
        try:
            sched = build_rolling_schedule(self.catalog(), self.station, self.spec,
                                           self.settings, self.controller, now_s, keep=keep)
        except TrackerError as e:
            if strict:
                raise
            self.fault(f"schedule not recomputed ({why}): {e}")
            return
        for p in [*sched.chosen, *sched.skipped]:
            kept = self.state.passes.get(p.key)
            if kept is not None and p.state == "planned":
                p.state, p.reason = kept["state"], kept.get("reason", "")
        self.schedule = sched
        self.board.set_schedule(sched.entries())
        if self.keeper is None:
            self.board.set_elements([self._fixed_elements(sched)])
        n = len(sched.chosen)
        nxt = sched.due(now_s)
        self.say(f"schedule ({why}): {n} pass(es) in the next {self.settings.horizon_h:g} h"
                 + (f", next {nxt.target.name} at {iso_utc(nxt.pass_.aos)}" if nxt else "")
                 + ("" if n else _why_none(sched)))
        for p in sched.skipped:
            self._finish(p, "skipped", p.reason, chosen=False)

    def _fixed_elements(self, sched: RollingSchedule) -> dict[str, Any]:
        """The board's element line for a catalogue given once (no refresh)."""
        found = (getattr(getattr(p.target, "elements", None), "epoch", None)
                 for p in sched.chosen)
        epochs: list[datetime] = sorted({e for e in found if e is not None})
        age_h = None
        if epochs:
            mid = epochs[len(epochs) // 2]
            age_h = round((self.clock.now() - mid).total_seconds() / 3600.0, 1)
        return {"source": "catalogue given at the start", "count": len(self.catalog()),
                "age_h": age_h, "checked_utc": None, "note": "not refreshed"}

    def refresh_elements(self) -> None:
        if self.keeper is None:
            return
        changed = self.keeper.refresh()
        self.board.set_elements(self.keeper.ages(self.clock.now()))
        if changed or self.schedule is None:
            self.replan("new elements" if changed else "start",
                        strict=self.schedule is None)

    # -- the loop --------------------------------------------------------------------------
    def run(self, until_s: float | None = None,
            should_stop: Callable[[], bool] = _never) -> StationReport:
        """Run until ``until_s`` (POSIX s; None: until stopped) or ``should_stop`` (asked
        every cycle of a live pass too: a pass cut short stays planned, so a restart goes on
        with it)."""
        self._should_stop = should_stop
        self._load_state()
        self.say(f"station {self.station.name}: {self.spec.name} on {self.controller.name}; "
                 f"targets {', '.join(self.settings.targets) or '-'}; groups "
                 f"{', '.join(self.settings.groups) or '-'}")
        try:
            while not should_stop():
                now_s = self.clock.timestamp()
                if until_s is not None and now_s >= until_s:
                    break
                self._between_passes()
                now_s = self.clock.timestamp()
                p = self.schedule.due(now_s) if self.schedule is not None else None
                start_s = self._start_s(p) if p is not None else math.inf
                if p is not None and now_s >= start_s:
                    self._run_pass(p)
                    continue
                wake_s = min(start_s, now_s + NAP_S,
                             until_s if until_s is not None else math.inf)
                self._idle(p, wake_s - now_s)
        finally:
            self.report.ended_utc = iso_utc(self.clock.now())
            self.board.set_state("stopped", "service ended")
        return self.report

    def _between_passes(self) -> None:
        if self._reload_wanted and self._reload is not None:
            self._reload_wanted = False
            self.say("reloading the configuration (SIGHUP)")
            old = self.settings, self.stream
            try:
                self._reload()
                self.replan("configuration reloaded", strict=True)
            except TrackerError as e:
                self.settings, self.stream = old
                self.fault(f"configuration not reloaded, the old one stays: {e}")
        if self.keeper is not None and self.keeper.due():
            self.refresh_elements()
        now_s = self.clock.timestamp()      # a refresh or a reload takes (real) time
        if self.schedule is None or now_s - self.schedule.computed_s >= REPLAN_S \
                or now_s < self.schedule.computed_s:
            self.replan("start" if self.schedule is None else "hourly",
                        strict=self.schedule is None)
        self._skip_missed(now_s)

    def _idle(self, nxt: PlannedPass | None, wait_s: float) -> None:
        if self.control is not None and getattr(self.control, "owner", "") != "outside":
            self.control.hand_over()
        detail = (f"next: {nxt.target.name} at {iso_utc(nxt.pass_.aos)}" if nxt is not None
                  else "no pass in the schedule")
        self.board.set_current_pass(None)
        self.board.set_target(None)
        self.board.set_state("handed_over" if self.control is not None else "idle", detail)
        wait_s = max(0.0, wait_s)
        before_s = self.clock.timestamp()
        self.clock.sleep(wait_s)
        drift_s = self.clock.timestamp() - (before_s + wait_s)
        if abs(drift_s) > CLOCK_JUMP_S:
            self.fault(f"the clock jumped {drift_s:+.0f} s")
            self.replan("clock jump")

    def _start_s(self, p: PlannedPass) -> float:
        """When the loop takes over for ``p``: AOS less the worst slew and the lead."""
        from tracker.geometry import slew_s

        worst = slew_s(self.spec, 0.0, 0.0, self.spec.az_span_deg,
                       180.0 if self.spec.has_elevation else None)
        return p.pass_.aos.timestamp() - float(worst) - LEAD_S - self.settings.settle_s

    def _park_after(self, p: PlannedPass) -> bool:
        """Park after ``p`` if the schedule says so and the park can end before the next
        pass is handed to the loop (back-to-back passes go straight from one to the next:
        a park still under way would spoil the next pass's pre-position)."""
        if not self.settings.park:
            return False
        nxt = next((q for q in (self.schedule.chosen if self.schedule else ())
                    if q.state == "planned" and q.pass_.aos > p.pass_.aos), None)
        if nxt is None:
            return True
        from tracker.geometry import slew_s

        worst = slew_s(self.spec, 0.0, 0.0, self.spec.az_span_deg,
                       180.0 if self.spec.has_elevation else None)
        return self._start_s(nxt) > p.pass_.los.timestamp() + float(worst) + PARK_MARGIN_S

    def _skip_missed(self, now_s: float) -> None:
        """Passes still planned whose LOS is past: nothing can be done for them now."""
        if self.schedule is None:
            return
        for p in self.schedule.chosen:
            if p.state == "planned" and p.pass_.los.timestamp() <= now_s:
                self._finish(p, "skipped", "missed: it ended while the station was busy, "
                                           "stopped or its controller unreachable")

    # -- one pass --------------------------------------------------------------------------
    def _run_pass(self, p: PlannedPass) -> None:
        from tracker.errors import PortLostError, RotatorIOError, StallError

        if self.control is not None:
            self.control.take_back(f"pass of {p.target.name} due at {iso_utc(p.pass_.aos)}")
        p.state = "tracking"
        self.board.update_pass(p.key, state="tracking")
        track = p.pass_.track(step_s=1.0, pad_s=60.0)
        t_s = np.arange(p.pass_.aos.timestamp(), p.pass_.los.timestamp() + PATH_STEP_S,
                        PATH_STEP_S)
        az, el = track.direction_at(np.minimum(t_s, p.pass_.los.timestamp()))
        self.board.set_current_pass({
            **p.entry(), "path": [[round(float(a), 1), round(float(e), 1)]
                                  for a, e in zip(az, el, strict=True)]})
        self.say(f"pass of {p.target.name}: AOS {iso_utc(p.pass_.aos)}, LOS "
                 f"{iso_utc(p.pass_.los)}, max el {p.pass_.max_el_deg:.0f} deg, {p.mode} "
                 f"({p.mode_reason})")
        watch = _PassWatch(self.board, self.spec, p.target.name, track, self.say)
        outcome = PassOutcome(p.key, p.target.name, iso_utc(p.pass_.aos), iso_utc(p.pass_.los),
                              p.mode, "done", max_el_deg=float(p.pass_.max_el_deg),
                              predicted_max_error_deg=p.predicted_max_error_deg,
                              pass_=p.pass_)
        try:
            if p.mode == "table":
                self._run_table(p, track, watch, outcome)
            else:
                self._run_stream(p, watch, outcome)
        except _CutShort:
            p.state = "planned"        # not an outcome: a restart goes on with this pass
            self.board.update_pass(p.key, state="planned")
            self.say(f"pass of {p.target.name} cut short: the station is stopping")
            return
        except StallError as e:
            outcome.outcome, outcome.reason = "failed", f"stall: {e}"
        except (PortLostError, RotatorIOError) as e:
            outcome.outcome, outcome.reason = "failed", f"controller unreachable: {e}"
        except TrackerError as e:
            outcome.outcome, outcome.reason = "failed", f"{type(e).__name__}: {e}"
        outcome.faults, outcome.starts = watch.faults, watch.starts
        outcome.travel_deg = watch.travel_deg
        if outcome.outcome == "failed":
            self.fault(f"pass of {p.target.name} failed: {outcome.reason}")
        self._finish(p, outcome.outcome, outcome.reason, outcome=outcome)

    def _run_stream(self, p: PlannedPass, watch: _PassWatch, outcome: PassOutcome) -> None:
        from dataclasses import replace

        from tracker.tracking import PassFollower

        settings = replace(self.stream, park_after_pass=self._park_after(p))
        follower = PassFollower(p.target, self.connect, self.spec, self.station, self.clock,
                                settings, events=watch.event, on_status=watch.status,
                                first=p.pass_)
        self._active = follower
        try:
            results = follower.run(1, should_stop=self._should_stop)
        finally:
            self._active = None
            follower.close()
        if not results:
            raise _CutShort()
        res = results[0]
        outcome.commands, outcome.reconnects = res.commands, res.reconnects
        self._measured(outcome, res)     # counted from acquisition by PassFollower.run

    @staticmethod
    def _measured(outcome: PassOutcome, result: PassResult) -> None:
        """The pass's measured max error, as ``result`` counts it: joined under way (a
        restart, a controller back late), from the first reading on target, and the reason
        says so (:meth:`PassResult.count_from_acquisition`)."""
        if result.joined_late_s > 0.0 and result.errors_deg:
            outcome.reason = result.joined_note()
        if math.isfinite(result.max_error_deg):
            outcome.measured_max_error_deg = float(result.max_error_deg)

    def _run_table(self, p: PlannedPass, track: Any, watch: _PassWatch,
                   outcome: PassOutcome) -> None:
        from tracker.planner import park_position
        from tracker.session import EffectiveLimits
        from tracker.steptable import compile_pass
        from tracker.stream import PassResult
        from tracker.upload import TableRunner, resume_schedule

        driver = self._active = self.connect()
        try:
            limits = EffectiveLimits.of(self.spec, self.station, driver.capabilities)
            spec = limits.rotator()
            az, el = driver.position()
            current = (float(spec.frame.nearest_mech_of_wire(az, spec.park_az_deg)),
                       float(el or 0.0))
            assert self.controller.step_tables is not None
            program = compile_pass(track, spec, self.station, self.controller.step_tables,
                                   current=current, interval_s=self.table_interval_s)
            self.board.set_state("uploading", f"step table for {p.target.name}")
            joined_s = self.clock.timestamp()
            # A pass under way resumes from the point due when the upload lands (stepping
            # from its first point would run the whole pass late).
            tables = resume_schedule(list(program.tables), joined_s)
            runner = TableRunner(driver, self.clock, spec=spec, sky=track,
                                 log=lambda m: watch.event("info", text=m),
                                 progress=watch.progress, on_reading=watch.reading)
            report = runner.run(tables)
            outcome.commands = sum(len(t) for t in tables) + len(tables)
            result = PassResult(commands=outcome.commands, reconnects=0,
                                max_error_deg=max(report.errors_deg, default=float("nan")),
                                errors_deg=list(report.errors_deg))
            result.count_from_acquisition(joined_s - p.pass_.aos.timestamp(),
                                          self.stream.deadband_deg)
            self._measured(outcome, result)
            if self._park_after(p):
                park_m, park_el = park_position(spec, self.station)
                park = (float(spec.frame.wire_of(park_m)),
                        float(park_el) if spec.has_elevation else None)
                limits.check_wire(*park)
                self.board.set_state("parking", f"{p.target.name}: after the step table")
                driver.goto(*park)
        finally:
            self._active = None
            driver.close()

    def _finish(self, p: PlannedPass, state: str, reason: str, *, chosen: bool = True,
                outcome: PassOutcome | None = None) -> None:
        p.state, p.reason = state, reason
        self.board.update_pass(p.key, state=state, reason=reason)
        if (p.key, chosen) in self._logged:
            return
        self._logged.add((p.key, chosen))
        if chosen:   # a pass a later schedule chose: its outcome replaces "not scheduled"
            self.report.outcomes = [o for o in self.report.outcomes
                                    if o.key != p.key or o.chosen]
        if outcome is None:
            outcome = PassOutcome(p.key, p.target.name, iso_utc(p.pass_.aos),
                                  iso_utc(p.pass_.los), p.mode, state, reason,
                                  chosen=chosen, max_el_deg=float(p.pass_.max_el_deg),
                                  predicted_max_error_deg=p.predicted_max_error_deg,
                                  pass_=p.pass_)
        self.report.outcomes.append(outcome)
        if not chosen:
            # in the schedule with its reason, and in the report; not a pass of the station's
            # (a later schedule may choose it, so the state file must not hold it)
            return
        record = outcome.record()
        self.board.add_pass(record)
        self.say(f"pass of {p.target.name} {state}" + (f": {reason}" if reason else "")
                 + (f"; measured max error {outcome.measured_max_error_deg:.1f} deg"
                    if outcome.measured_max_error_deg is not None else ""))
        self.state.note(p.key, state, reason, p.pass_.los.timestamp())
        self.state.prune(self.clock.timestamp())
        self._save(record)

    # -- persistence -----------------------------------------------------------------------
    def _load_state(self) -> None:
        if self.state_path is None:
            return
        self.state, warning = StationState.load(self.state_path)
        if warning:
            self.fault(warning)
        elif self.state.passes:
            self.say(f"state {self.state_path}: {len(self.state.passes)} recent pass "
                     f"outcome(s) picked up")

    def _save(self, record: dict[str, Any]) -> None:
        try:
            if self.pass_log is not None:
                self.pass_log.write(record)
            if self.state_path is not None:
                self.state.save(self.state_path)
        except (OSError, ConfigError) as e:
            # A full disk must not stop tracking: the state is kept in memory meanwhile.
            self.fault(f"could not write the pass log or state file: {e}")

