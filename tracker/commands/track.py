"""``tracker track TARGET``: follow passes live on a rotator, or on the built-in emulator.

Without ``--port`` (and no ``[tracking] port`` in the config) this is a demo: the built-in
emulator of ``--protocol`` (GS-232B with a G-5500 by default; the Rotor-EZ, DCU-1, SAK-232 and
AZ/AZ emulators with their own azimuth-only rotator unless ``--rotator`` names one) runs
in-process on a simulated clock that starts shortly before the target's next pass and runs
``--speed`` times faster, so a whole pass shows in about a minute. It says so plainly. With
``--port`` everything runs in real time on the real rotator.

With ``--protocol gs232b-azaz --target2 TARGET2`` the two azimuth-only antennas of one
GS-232B-AZ/AZ interface track two targets at once over the one port: one loop per antenna
(the same pass-by-pass loop as a single antenna: own plan, passes, deadband, park/stay, stall
guard), each on its own axis of one shared driver, which serialises the requests and is
reopened once when the port is lost. A stall, an error or Ctrl-C/SIGTERM on either stops both
(``S``) and ends the run. The demo runs both antennas on the built-in AZ/AZ emulator from
shortly before the earlier of the two first passes, at a speed that shows the longer pass in
about a minute; simulated idle time is skipped only while both antennas wait for a pass.
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone

from tracker.clock import LockstepClock, SimClock
from tracker.commands._common import (
    add_station_args,
    add_target_args,
    add_time_args,
    check_baud_arg,
    config_from_args,
    parse_utc,
    protocol_help,
    station_from_args,
    target_from_args,
    warn_element_age,
)
from tracker.errors import ConfigError, TargetError, TrackerError
from tracker.transport import is_emulated

DEMO_SECONDS = 60.0        # a whole demo pass in about this much wall time
STALE_ELEMENTS_DAYS = 14.0  # older elements: the demo replays a pass near their epoch
PASS_SEARCH_DAYS = 3.0
PAD_S = 60.0
IDLE_SKIP_MIN_S = 30.0      # the demo skips idle stretches longer than this
JOIN_TIMEOUT_S = 10.0       # an antenna loop notices a stop within a cycle or a read timeout


def register(sub) -> None:
    p = sub.add_parser(
        "track", help="track a target live (built-in emulator demo without --port)",
        description="Follow the next pass(es) of TARGET with the rotator: pre-position, "
                    "deadband moves aimed ahead of the target, read-back every cycle, "
                    "reconnect on port loss, park after the pass. Without --port the "
                    "built-in emulator of --protocol (default GS-232B with a G-5500) runs a "
                    "simulated pass. With --protocol gs232b-azaz --target2 TARGET2 the two "
                    "antennas of a GS-232B-AZ/AZ interface track two targets at once.")
    p.add_argument("target", help='satellite name or NORAD id (e.g. "ISS (ZARYA)"), Sun, Moon')
    p.add_argument("--target2", metavar="TARGET2",
                   help="with --protocol gs232b-azaz: antenna 2 of the GS-232B-AZ/AZ "
                        "interface tracks TARGET2 while antenna 1 tracks TARGET, both over "
                        "the one port (each with its own plan; --passes, --deadband, "
                        "--park/--stay apply to each; a stall or Ctrl-C on either stops both)")
    p.add_argument("--port", help="serial port or pyserial URL of the controller "
                                  "(/dev/ttyUSB0, COM3, socket://host:port); default: the "
                                  "[tracking] port of the config, else the built-in emulator")
    p.add_argument("--protocol",
                   help=protocol_help())
    p.add_argument("--baud", type=int, help="baud rate (default: the protocol's)")
    p.add_argument("--rotator", help="rotator preset or [rotator.NAME] (default G-5500; "
                                     "with --target2: antenna 1's, and antenna 2's too unless "
                                     "--rotator2)")
    p.add_argument("--rotator2", metavar="ROTATOR",
                   help="with --target2: antenna 2's rotator (default: the same as --rotator)")
    p.add_argument("--passes", type=int, default=1, metavar="N",
                   help="passes to track in a row, re-planning from the real antenna "
                        "position between them; 0 = until Ctrl-C (default 1)")
    p.add_argument("--speed", type=_speed_arg, metavar="F",
                   help="simulation speed factor (emulator demo, or with --at); default so "
                        "a pass shows in about a minute; 'max': no waiting at all (virtual "
                        "time, emulators only; the default with --port emu://... and --at)")
    p.add_argument("--deadband", type=float, metavar="DEG",
                   help="pointing error tolerated before moving (default: the rotator's)")
    p.add_argument("--cycle", type=float, metavar="S", help="read-back cycle, s (default 0.5)")
    park = p.add_mutually_exclusive_group()
    park.add_argument("--park", dest="park", action="store_true", default=None,
                      help="park after each pass (default, or [tracking] park_after_pass)")
    park.add_argument("--stay", dest="park", action="store_false",
                      help="stay where the pass ended")
    p.add_argument("--log", metavar="FILE", help="append JSON lines of every command, reply "
                                                 "and state change to FILE")
    p.add_argument("--plain", action="store_true",
                   help="timestamped lines instead of the live panel (two antennas always "
                        "show as lines prefixed ant1/ant2)")
    add_station_args(p)
    add_target_args(p)
    add_time_args(p)
    p.set_defaults(func=run)


def _start_time(args, target, demo: bool) -> tuple[datetime, str]:
    """Where the search for the next pass starts, and a note if the demo moved it."""
    if args.at is not None:
        return parse_utc(args.at), ""
    now = datetime.now(timezone.utc)  # CLI boundary: the only place the real time is read
    elements = getattr(target, "elements", None)
    epoch = getattr(elements, "epoch", None)
    if demo and epoch is not None:
        age = (now - epoch).total_seconds() / 86400.0
        if age > STALE_ELEMENTS_DAYS:
            return epoch, (f"the elements for {target.name} are {age:.0f} days old (epoch "
                           f"{epoch:%Y-%m-%d %H:%M} UTC): the simulation replays a pass just "
                           f"after their epoch. `tracker tle update` fetches current ones.")
    return now, ""


def _next_pass(target, station, after_s: float):
    from tracker.passes import find_passes

    start = datetime.fromtimestamp(after_s, timezone.utc)
    passes = find_passes(target, station, start, start + timedelta(days=PASS_SEARCH_DAYS))
    passes = [p for p in passes if p.los.timestamp() > after_s + 30 and not p.always_up]
    if not passes:
        raise TargetError(f"{target.name} has no pass over {station.name} in the "
                          f"{PASS_SEARCH_DAYS:g} days after {start:%Y-%m-%d %H:%M} UTC "
                          f"(check the station position, --min-el and the mask)")
    return passes[0]


def _describe(p) -> str:
    return (f"{p.aos:%Y-%m-%d %H:%M:%S} UTC, max el {p.max_el_deg:.0f} deg, "
            f"{p.duration_s / 60:.1f} min")


def _settings(args, config, spec):
    from tracker.stream import StreamSettings

    tr = config.tracking
    deadband = args.deadband if args.deadband is not None else tr.get(
        "deadband_deg", spec.deadband_deg)
    if not (0.0 <= deadband <= 30.0):
        raise ConfigError(f"--deadband {deadband} is invalid; allowed: 0 to 30 degrees")
    cycle = args.cycle if args.cycle is not None else tr.get("update_interval_s", 0.5)
    if not (0.05 <= cycle <= 60.0):
        raise ConfigError(f"--cycle {cycle} is invalid; allowed: 0.05 to 60 seconds")
    park = args.park if args.park is not None else tr.get("park_after_pass", True)
    return StreamSettings(deadband_deg=float(deadband), cycle_s=float(cycle),
                          park_after_pass=bool(park))


@dataclass
class _Antenna:
    """One antenna following one target: its rotator, loop settings, link and UI sinks."""

    n: int                       # 1 or 2 (0: the single antenna of a one-target run)
    target: object
    spec: object
    settings: object
    first: object                # the first pass to track
    link: object = None
    out: object = None
    ui: object = None
    results: list = field(default_factory=list)

    @property
    def label(self) -> str:
        return f"ant{self.n} {self.target.name}" if self.n else ""


class _DemoTime:
    """Simulated time of the demo, shared by its antennas: paused while any of them plans
    (pass searches are slow at a high speed), and idle stretches before a pass skipped only
    when every antenna still tracking is waiting for its next pass."""

    def __init__(self, clock: SimClock, antennas: list[int]):
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
        with self._cv:
            self._holders.add(n)
            self._apply()

    def release(self, n: int) -> None:
        with self._cv:
            self._holders.discard(n)
            self._apply()
            self._cv.notify_all()

    def leave(self, n: int) -> None:
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


def _follow_passes(ant: _Antenna, station, clock, passes: int, timer: _DemoTime | None,
                   should_stop: Callable[[], bool] = lambda: False) -> None:
    """Track ``passes`` passes of ``ant.target`` in a row (0: until stopped), re-planning
    each from the real antenna position; results go to ``ant.results``."""
    from tracker.planner import plan_pass
    from tracker.stream import TrackCore, run_pass
    from tracker.trackui import RichPanel

    link, out, settings, spec, target = ant.link, ant.out, ant.settings, ant.spec, ant.target
    n = 0
    pas = ant.first
    while (passes == 0 or n < passes) and not should_stop():
        # Re-plan from the real antenna position (read back now, not assumed).
        link.events = out.event
        az, el = link.position()
        if timer is not None:
            timer.hold(ant.n)
        try:
            current = _mech_guess(spec, az, el)
            track = pas.track(step_s=1.0, pad_s=PAD_S)
            plan = plan_pass(track, spec, station, current=current,
                             park=settings.park_after_pass)
            try:
                nxt = _next_pass(target, station, pas.los.timestamp() + 60.0)
            except TargetError:
                nxt = None
        finally:
            if timer is not None:
                timer.release(ant.n)
        if isinstance(ant.ui, RichPanel):
            ant.ui.next_pass = _describe(nxt) if nxt is not None else "none in the next days"
        out.event("info", text=f"pass {n + 1}: {target.name} {_describe(pas)}; mode "
                               f"{plan.mode}: {plan.reason}")
        out.event("state", state="plan", mode=plan.mode,
                  predicted_max_error_deg=round(plan.max_error_deg, 2),
                  aos=pas.aos.isoformat(), los=pas.los.isoformat())
        if timer is not None:
            lead = min(plan.preposition_t_s, pas.aos.timestamp() - 120.0) - 10.0
            timer.idle_until(ant.n, lead, lambda text: out.event("info", text=text),
                             should_stop)
        core = TrackCore(plan, track, spec, station, settings)
        res = run_pass(core, link, clock, on_status=out.status, events=out.event,
                       should_stop=should_stop)
        if not res.completed:
            break                                   # stopped: the caller says why
        err = res.errors_deg
        p99 = sorted(err)[max(0, math.ceil(0.99 * len(err)) - 1)] if err else float("nan")
        ant.results.append(res)
        out.event("info", text=f"pass {n + 1} done: {res.commands} commands, max error "
                               f"{res.max_error_deg:.1f} deg (p99 {p99:.1f}, plan "
                               f"predicted {plan.max_error_deg:.1f} + deadband "
                               f"{settings.deadband_deg:g}), {res.reconnects} reconnects")
        out.event("state", state="pass_done", commands=res.commands,
                  max_error_deg=round(res.max_error_deg, 2), p99_error_deg=round(p99, 2),
                  reconnects=res.reconnects)
        n += 1
        if nxt is None:
            break
        pas = nxt


class _SharedAzAz:
    """One GS-232B-AZ/AZ interface shared by both antennas' loops: opened once, reopened
    once (under a lock) after the port was lost, ``S`` (all-stop) for both. Its driver
    serialises requests itself (:class:`Gs232Driver` holds a lock per request)."""

    def __init__(self, open_fn: Callable[[], object]):
        self._open = open_fn
        self._lock = threading.Lock()
        self._drv = None
        self._gen = 0
        self.finished = False     # the run's final S went out: nothing may move after it

    def final_stop(self) -> bool:
        """The run's last word, ``S``; a loop that outlives the join can only stop after it."""
        self.finished = True
        return self.all_stop()

    def axis(self, n: int) -> _AxisLease:
        with self._lock:
            if self._drv is None:
                self._drv = self._open()
                self._gen += 1
            return _AxisLease(self, self._drv.axis(n), self._gen)

    def lost(self, gen: int) -> None:
        """A loop lost the port of generation ``gen``: close it (once), so the next
        ``axis()`` reopens; a loop still on an older generation changes nothing."""
        with self._lock:
            if gen == self._gen:
                self._close()

    def _close(self) -> None:
        drv, self._drv = self._drv, None
        if drv is not None:
            try:
                drv.close()
            except (TrackerError, OSError):
                pass   # the port is already gone; nothing more to release

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

    def close(self) -> None:
        with self._lock:
            self._close()


class _AxisLease:
    """One antenna's view of the shared interface, as a :class:`Link` driver: closing it
    (what the loop does when the port is lost) reports the loss instead of closing the
    port under the other antenna."""

    def __init__(self, shared: _SharedAzAz, axis, gen: int):
        self.shared, self.axis, self.gen = shared, axis, gen
        self.capabilities = axis.capabilities

    def position(self):
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


class _PrefixedLines:
    """Plain timestamped lines of one antenna: ``02:07:10  ant1 ISS (ZARYA)  command ...``."""

    def __init__(self, clock, prefix: str):
        from tracker.trackui import PlainLines

        self.prefix = prefix
        self.lines = PlainLines(clock, stream=self)

    def write(self, text: str) -> None:
        # PlainLines writes "HH:MM:SS  text\n" in one call: put the antenna after the time.
        hms, sep, rest = text.partition("  ")
        sys.stdout.write(f"{hms}{sep}{self.prefix}  {rest}" if sep else text)

    def flush(self) -> None:
        sys.stdout.flush()


class _AntennaOut:
    """One antenna's sinks: its prefixed plain lines and the shared JSON log (records carry
    ``antenna``); one lock, so the two loops' lines never interleave."""

    def __init__(self, n: int, prefix: str, clock, log, lock: threading.Lock):
        self.n, self.log, self.lock = n, log, lock
        self.lines = _PrefixedLines(clock, prefix).lines

    def event(self, kind: str, **data) -> None:
        with self.lock:
            self.lines.event(kind, **data)
            if self.log is not None:
                self.log.event(kind, antenna=self.n, **data)

    def status(self, st) -> None:
        with self.lock:
            self.lines.status(st)

    def close(self) -> None:
        return None


# The command's whole flow; its logic is to move into the library, and gets split then.
def run(args: argparse.Namespace) -> int:  # noqa: C901
    from tracker.controllers import controller
    from tracker.protocols import open_driver
    from tracker.session import ControllerSession, driver_limits
    from tracker.stream import Link
    from tracker.trackui import Fanout, JsonLinesLog, PlainLines, RichPanel

    check_baud_arg(args)
    if args.passes < 0:
        raise ConfigError(f"--passes {args.passes} is invalid; use 1 or more, or 0 for "
                          f"'until Ctrl-C'")
    if args.speed is not None and args.speed != math.inf and not (0 < args.speed <= 1000):
        raise ConfigError(f"--speed {args.speed} is invalid; allowed: > 0 to 1000, or max")
    config = config_from_args(args)
    tr = config.tracking
    port = args.port or tr.get("port")
    protocol = args.protocol or tr.get("protocol") or "gs232b"
    entry = controller(protocol)
    dual = args.target2 is not None
    if args.rotator2 and not dual:
        raise ConfigError("--rotator2 names antenna 2's rotator; it needs --target2 TARGET2 "
                          "(and --protocol gs232b-azaz)")
    if dual and not (entry.dual_azimuth and protocol.lower() == entry.name):
        raise ConfigError(f"--target2 needs --protocol gs232b-azaz (two azimuth-only antennas "
                          f"on one GS-232B-AZ/AZ interface); {protocol} drives one rotator: "
                          f"run one 'tracker track' per rotator instead")
    demo = not port
    if demo and entry.emulator is None:
        raise ConfigError(f"--protocol {protocol} needs --port {entry.port_hint}")
    emulator = entry.name if demo else None
    station = station_from_args(args)
    spec = config.rotator(args.rotator)
    targets = [target_from_args(args.target, args)]
    if dual:
        targets.append(target_from_args(args.target2, args))
    if emulator and not (args.rotator or tr.get("rotator")):
        spec = config.rotator(entry.default_rotator)
    specs = [spec]
    if dual:
        specs.append(config.rotator(args.rotator2) if args.rotator2 else spec)
    for i, s in enumerate(specs):
        if not entry.has_elevation and s.has_elevation:
            raise ConfigError(f"protocol {protocol} drives an azimuth-only rotator, but "
                              f"rotator {s.name} has elevation; pass "
                              f"{('--rotator', '--rotator2')[i]} with an azimuth-only one "
                              f"(e.g. G-400, or a [rotator.NAME] without el_max_deg)")
    ants = [_Antenna(i + 1 if dual else 0, t, s, _settings(args, config, s), None)
            for i, (t, s) in enumerate(zip(targets, specs, strict=True))]

    starts = [_start_time(args, t, demo) for t in targets]
    start = min(s for s, _note in starts)
    warn_element_age(targets, start)  # the demo moved to a stale epoch says so in its note
    notes = [note for _s, note in starts if note]
    for a in ants:
        a.first = _next_pass(a.target, station, start.timestamp())
    simulated = demo or args.at is not None
    emulated = demo or is_emulated(port)
    # Virtual time: the loops and an in-process emulator on one clock that moves only when
    # every loop waits (LockstepClock); every wait is a jump of the clock.
    virtual = args.speed == math.inf or (bool(args.at) and emulated and not demo
                                         and args.speed is None)
    simulated = simulated or virtual   # --speed max runs on virtual time from now
    if virtual and not emulated:
        raise ConfigError("--speed max needs an emulated controller: the built-in one (no "
                          "--port) or --port emu://PROTOCOL; a real rotator runs in real time")
    if virtual:
        earliest = min(a.first.aos for a in ants)
        from tracker.emulator.virtual import clock_of

        # an emu:// bench made by the caller brings its own clock; else a new one
        clock = clock_of(port) if port and is_emulated(port) else None
        clock = clock or LockstepClock(max(start, earliest - timedelta(seconds=150))
                                       if demo else start, parties=len(ants))
    elif simulated:
        # fast enough that the longest of the (first) passes shows in about DEMO_SECONDS
        span = max(a.first.los.timestamp() - max(a.first.aos.timestamp() - 120.0,
                                                  start.timestamp()) for a in ants)
        speed = args.speed or max(1.0, round(span / DEMO_SECONDS))
        if demo:
            earliest = min(a.first.aos for a in ants)
            clock = SimClock(max(start, earliest - timedelta(seconds=150)), speed)
        else:
            clock = SimClock(start, speed)
    else:
        from tracker.clock import SystemClock

        if args.speed is not None:
            raise ConfigError("--speed needs the built-in emulator (no --port) or --at; a "
                              "real rotator runs in real time")
        clock = SystemClock()
    timer = _DemoTime(clock, [a.n for a in ants]) if demo and not virtual else None
    # Opened before any emulator starts or byte is sent: a bad path ends the run here.
    log = JsonLinesLog(args.log, clock) if args.log else None

    server = None
    if demo:
        from tracker.emulator.factory import make_emulator
        from tracker.emulator.virtual import Bench

        box = make_emulator(emulator, clock, specs[0], **({"spec2": specs[1]} if dual else {}))
        server = Bench(box)              # in-process: emu://bench-N, no socket
        url = server.url
    else:
        url = port

    def driver_kw(s) -> dict:
        kw = driver_limits(s)
        if args.baud or tr.get("baudrate"):
            kw["baudrate"] = args.baud or tr.get("baudrate")
        return kw

    def connect():
        kw = driver_kw(spec)
        # The loop's (possibly simulated) clock: an open-loop driver runs its motor-model
        # estimate on it, an emu:// controller runs on it; read timeouts stay on the port's
        # own time either way.
        kw["clock"] = clock
        if entry.open_loop:
            kw["spec"] = spec
        drv = open_driver(url, protocol, **kw)
        if not drv.capabilities.has_position_query and not open_loop_said:
            open_loop_said.append(True)
            out.event("info", text=f"{protocol} has no position query: tracking open loop "
                                   f"on the {spec.name} motor model's estimate, which assumes "
                                   f"the antenna starts at its park position (calibrate: "
                                   f"park it against its stop first); 'antenna' below is "
                                   f"that estimate, not a reading")
        return drv

    open_loop_said: list[bool] = []
    banner = ""
    if demo:
        rot = (f"two azimuth-only antennas (ant1 {specs[0].name}, ant2 {specs[1].name})"
               if dual else f"a {spec.name}")
        pace = "virtual time (no waiting)" if virtual else f"{clock.speed:g}x speed"
        banner = (f"SIMULATION: built-in {emulator} emulator with {rot} at {pace}; no real "
                  f"rotator moves. Use --port to drive one.")
    # Two antennas show as plain lines (prefixed ant1/ant2), on a terminal too.
    tty = sys.stdout.isatty() and not args.plain and not dual
    shared = None
    if dual:
        lock = threading.Lock()
        shared = _SharedAzAz(lambda: open_driver(url, protocol, clock=clock,
                                                 **driver_kw(spec)))
        out = Fanout(PlainLines(clock), log)   # run-wide lines and records (no antenna)
        for a in ants:
            a.out = _AntennaOut(a.n, a.label, clock, log, lock)
            a.link = Link(lambda n=a.n: shared.axis(n), a.spec)
    else:
        ui = RichPanel(clock, f"tracker track {targets[0].name}", banner) if tty \
            else PlainLines(clock)
        out = Fanout(ui, log)
        ants[0].out, ants[0].ui = out, ui
        ants[0].link = Link(connect, spec)

    def all_stop() -> bool:
        # The session's last word: S after whatever the loops sent (run_pass stops on its
        # way out too; this covers a signal or an error outside a pass, e.g. while planning).
        # A failed stop is reported here (Link.stop reports its own), never raised over the
        # error that ended the run.
        if shared is None:
            return all([a.link.stop() for a in ants])
        if shared.final_stop():
            return True
        out.event("state", state="stop_failed", reason="all-stop S did not reach the "
                                                       "controller")
        return False

    try:
        with ControllerSession(all_stop, stop_at_end=False):
            if banner and not tty:
                out.event("info", text=banner)
            for note in notes:
                out.event("info", text=note)
            for a in ants:
                a.out.event("state", state="start", target=a.target.name, port=url,
                            protocol=protocol, rotator=a.spec.name, simulated=simulated,
                            speed="max" if virtual else clock.speed)
            if dual:
                _run_both(ants, shared, station, clock, args.passes, timer, out)
            else:
                _plan_inside_the_controller(ants[0], station, out)
                _follow_passes(ants[0], station, clock, args.passes, timer)
    finally:
        for a in ants:
            a.link.drop()
        if shared is not None:
            shared.close()
        out.close()
        if server is not None:
            server.close()
    for a in ants:
        for i, res in enumerate(a.results, 1):
            print((f"{a.label}: " if a.label else "")
                  + f"pass {i}: {res.commands} commands sent, max pointing error "
                  f"{res.max_error_deg:.1f} deg, {res.reconnects} reconnects"
                  + (" (simulated)" if simulated else ""))
    return 0


def _plan_inside_the_controller(ant: _Antenna, station, out) -> None:
    """Effective limits, once, before planning: the rotator spec narrowed by what the
    connected controller accepts (rotctld's limits, a 360 deg mode), so every pass is planned
    inside them instead of failing on a move the controller refuses."""
    from tracker.session import EffectiveLimits

    limits = EffectiveLimits.of(ant.spec, station, ant.link.ensure().capabilities)
    spec = limits.rotator()
    if spec != ant.spec:
        out.event("info", text=f"planning inside the controller's limits: {limits.describe()}")
        ant.spec = ant.link.spec = spec

def _speed_arg(text: str) -> float:
    """``--speed``: a factor, or ``max`` for virtual time."""
    if str(text).strip().lower() == "max":
        return math.inf
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or 'max'") from None


# Two-antenna flow of the track command; split with run() when it moves into the library.
def _run_both(ants: list[_Antenna], shared: _SharedAzAz, station, clock, passes: int,  # noqa: C901
              timer: _DemoTime | None, out) -> None:
    """Both antennas at once, one thread each on the shared interface. A stall, an error or
    Ctrl-C/SIGTERM on either stops both (``S``) and ends the run; every way out ends
    with ``S``."""
    stop = threading.Event()
    failures: list[tuple[_Antenna, BaseException]] = []

    def work(a: _Antenna) -> None:
        try:
            _follow_passes(a, station, clock, passes, timer, should_stop=stop.is_set)
        except BaseException as e:   # any end of a loop ends both; the main thread reports
            failures.append((a, e))
            stop.set()
            shared.all_stop()        # at once: the other loop notices within a cycle
        finally:
            if timer is not None:
                timer.leave(a.n)
            leave = getattr(clock, "leave", None)
            if leave is not None:    # virtual time: the other loop no longer waits for this one
                leave()

    threads = [threading.Thread(target=work, args=(a,), name=f"track-ant{a.n}", daemon=True)
               for a in ants]
    try:
        for t in threads:
            t.start()
        while any(t.is_alive() for t in threads):
            for t in threads:
                t.join(timeout=0.2)   # short joins: Ctrl-C/SIGTERM reach this thread
    except KeyboardInterrupt:
        stop.set()
        shared.all_stop()
        out.event("info", text="interrupted: all-stop (S) sent to both antennas")
        raise
    finally:
        stop.set()
        for t in threads:
            t.join(timeout=JOIN_TIMEOUT_S)
        # Last word on the wire: S, after both loops sent their own A / E.
        if shared.final_stop():
            out.event("command", cmd="stop", note="S: both antennas")
        else:
            out.event("state", state="stop_failed", reason="all-stop S did not reach the "
                                                           "controller")
    if failures:
        a, e = failures[0]
        if not isinstance(e, TrackerError):
            raise e                  # a bug, not a rotator problem: keep its traceback
        raise TrackerError(f"antenna {a.n} ({a.target.name}): {e}; all-stop (S) sent, both "
                           f"antennas stopped") from e


def _mech_guess(spec, wire_az: float, wire_el):
    """The antenna's mechanical position from a read-back with no history: trust the
    controller's own scale (a 450 deg controller reports 0-450)."""
    from tracker.stream import mech_candidates_of_wire

    if wire_az < 0:
        raise ConfigError("the controller reports no position (AZ=-001: control box off?); "
                          "switch the rotator's control box on and retry")
    cands = mech_candidates_of_wire(spec, wire_az)
    m = min(cands, key=lambda c: abs(c - wire_az)) if not spec.controller_maps_south \
        else cands[0]
    return (m, float(wire_el) if wire_el is not None else 0.0)
