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
from dataclasses import dataclass, field
from datetime import datetime, timezone
from functools import partial
from typing import TYPE_CHECKING

from tracker.clock import Clock, LockstepClock, SimClock
from tracker.commands._common import (
    add_station_args,
    add_target_args,
    add_time_args,
    check_baud_arg,
    config_from_args,
    parse_utc,
    protocol_help,
    speed_arg,
    station_from_args,
    stream_settings,
    target_from_args,
    warn_element_age,
)
from tracker.errors import ConfigError, TargetError
from tracker.transport import is_emulated

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.controllers import Controller
    from tracker.mount import RotatorSpec
    from tracker.passes import Pass
    from tracker.station import Station
    from tracker.stream import StreamSettings
    from tracker.targets import Target


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
    p.add_argument("--speed", type=speed_arg, metavar="F",
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
    from tracker.tracking import demo_start

    if args.at is not None:
        return parse_utc(args.at), ""
    now = datetime.now(timezone.utc)  # CLI boundary: the only place the real time is read
    return demo_start(target, now) if demo else (now, "")


def _first_pass(target, station, start: datetime):
    from tracker.tracking import next_pass

    try:
        return next_pass(target, station, start.timestamp())
    except TargetError as e:
        raise TargetError(f"{e} (check the station position, --min-el and the mask)") from e


@dataclass
class _Run:
    """What the flags name: the controller, the antennas' targets and rotators, and where the
    search for their passes starts."""

    args: argparse.Namespace
    port: str | None
    protocol: str
    entry: Controller
    station: Station
    targets: list[Target]
    specs: list[RotatorSpec]
    settings: list[StreamSettings]
    start: datetime
    notes: list[str]
    firsts: list[Pass] = field(default_factory=list)

    @property
    def dual(self) -> bool:
        return len(self.targets) == 2

    @property
    def demo(self) -> bool:
        return not self.port

    @property
    def numbers(self) -> list[int]:
        """Each antenna's number: 1 and 2 of a two-antenna run, 0 for a single one."""
        return [1, 2] if self.dual else [0]


def _check_args(args) -> None:
    check_baud_arg(args)
    if args.passes < 0:
        raise ConfigError(f"--passes {args.passes} is invalid; use 1 or more, or 0 for "
                          f"'until Ctrl-C'")
    if args.speed is not None and args.speed != math.inf and not (0 < args.speed <= 1000):
        raise ConfigError(f"--speed {args.speed} is invalid; allowed: > 0 to 1000, or max")


def _controller(args, config):
    """The port (None: the demo), the protocol and its registry entry, checked against the
    flags."""
    from tracker.controllers import controller

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
    if not port and entry.emulator is None:
        raise ConfigError(f"--protocol {protocol} needs --port {entry.port_hint}")
    return port, protocol, entry


def _resolve(args) -> _Run:
    config = config_from_args(args)
    port, protocol, entry = _controller(args, config)
    demo = not port
    station = station_from_args(args)
    spec = config.rotator(args.rotator)
    targets = [target_from_args(args.target, args)]
    if args.target2 is not None:
        targets.append(target_from_args(args.target2, args))
    if demo and not (args.rotator or config.tracking.get("rotator")):
        spec = config.rotator(entry.default_rotator)
    specs = [spec]
    if len(targets) == 2:
        specs.append(config.rotator(args.rotator2) if args.rotator2 else spec)
    for i, s in enumerate(specs):
        if not entry.has_elevation and s.has_elevation:
            raise ConfigError(f"protocol {protocol} drives an azimuth-only rotator, but "
                              f"rotator {s.name} has elevation; pass "
                              f"{('--rotator', '--rotator2')[i]} with an azimuth-only one "
                              f"(e.g. G-400, or a [rotator.NAME] without el_max_deg)")
    settings = [stream_settings(config, s, deadband_deg=args.deadband, cycle_s=args.cycle,
                                park=args.park) for s in specs]
    starts = [_start_time(args, t, demo) for t in targets]
    start = min(s for s, _note in starts)
    warn_element_age(targets, start)  # the demo moved to a stale epoch says so in its note
    run = _Run(args, port, protocol, entry, station, targets, specs, settings, start,
               [note for _s, note in starts if note])
    run.firsts = [_first_pass(t, station, start) for t in targets]
    return run


def _clock(run: _Run) -> tuple[Clock, bool, bool]:
    """The run's clock, whether it is virtual (every wait a jump of the clock) and whether
    it is simulated at all."""
    from tracker.tracking import demo_clock_start, demo_speed

    args, port, demo = run.args, run.port, run.demo
    emulated = demo or is_emulated(port)
    # Virtual time: the loops and an in-process emulator on one clock that moves only when
    # every loop waits (LockstepClock); every wait is a jump of the clock.
    virtual = args.speed == math.inf or (bool(args.at) and emulated and not demo
                                         and args.speed is None)
    simulated = demo or args.at is not None or virtual  # --speed max: virtual time from now
    if virtual and not emulated:
        raise ConfigError("--speed max needs an emulated controller: the built-in one (no "
                          "--port) or --port emu://PROTOCOL; a real rotator runs in real time")
    start = demo_clock_start(run.firsts, run.start) if demo else run.start
    if virtual:
        from tracker.emulator.virtual import clock_of

        # an emu:// bench made by the caller brings its own clock; else a new one
        clock = clock_of(port) if port and is_emulated(port) else None
        return clock or LockstepClock(start, parties=len(run.targets)), True, True
    if simulated:
        return SimClock(start, args.speed or demo_speed(run.firsts, run.start)), False, True
    if args.speed is not None:
        raise ConfigError("--speed needs the built-in emulator (no --port) or --at; a "
                          "real rotator runs in real time")
    from tracker.clock import SystemClock

    return SystemClock(), False, False


def _opener(run: _Run, url: str, clock: Clock, out):
    """The connect callable of the run's driver (antenna 1's rotator sets its scale)."""
    from tracker.protocols import open_driver
    from tracker.session import driver_limits

    spec, protocol, tr = run.specs[0], run.protocol, config_from_args(run.args).tracking
    kw = driver_limits(spec)
    if run.args.baud or tr.get("baudrate"):
        kw["baudrate"] = run.args.baud or tr.get("baudrate")
    # The loop's (possibly simulated) clock: an open-loop driver runs its motor-model
    # estimate on it, an emu:// controller runs on it; read timeouts stay on the port's
    # own time either way.
    kw["clock"] = clock
    if run.dual:
        return partial(open_driver, url, protocol, **kw)
    if run.entry.open_loop:
        kw["spec"] = spec
    said: list[bool] = []

    def connect():
        drv = open_driver(url, protocol, **kw)
        if not drv.capabilities.has_position_query and not said:
            said.append(True)
            out.event("info", text=f"{protocol} has no position query: tracking open loop "
                                   f"on the {spec.name} motor model's estimate, which assumes "
                                   f"the antenna starts at its park position (calibrate: "
                                   f"park it against its stop first); 'antenna' below is "
                                   f"that estimate, not a reading")
        return drv
    return connect


def _banner(run: _Run, clock: Clock, virtual: bool) -> str:
    if not run.demo:
        return ""
    specs = run.specs
    rot = (f"two azimuth-only antennas (ant1 {specs[0].name}, ant2 {specs[1].name})"
           if run.dual else f"a {specs[0].name}")
    pace = "virtual time (no waiting)" if virtual else f"{clock.speed:g}x speed"
    return (f"SIMULATION: built-in {run.entry.name} emulator with {rot} at {pace}; no real "
            f"rotator moves. Use --port to drive one.")


def run(args: argparse.Namespace) -> int:
    from tracker.session import ControllerSession
    from tracker.tracking import DemoTime
    from tracker.trackui import JsonLinesLog

    _check_args(args)
    r = _resolve(args)
    clock, virtual, simulated = _clock(r)
    timer = DemoTime(clock, r.numbers) if r.demo and not virtual else None
    # Opened before any emulator starts or byte is sent: a bad path ends the run here.
    log = JsonLinesLog(args.log, clock) if args.log else None
    server = None
    if r.demo:
        from tracker.emulator.factory import make_emulator
        from tracker.emulator.virtual import Bench

        box = make_emulator(r.entry.name, clock, r.specs[0],
                            **({"spec2": r.specs[1]} if r.dual else {}))
        server = Bench(box)              # in-process: emu://bench-N, no socket
    url = server.url if server is not None else r.port
    banner = _banner(r, clock, virtual)
    # Two antennas show as plain lines (prefixed ant1/ant2), on a terminal too.
    tty = sys.stdout.isatty() and not args.plain and not r.dual
    wire = _two_antennas if r.dual else _one_antenna
    followers, out, all_stop, follow, close = wire(r, url, clock, timer, log, banner, tty)
    try:
        with ControllerSession(all_stop, stop_at_end=False):
            if banner and not tty:
                out.event("info", text=banner)
            for note in r.notes:
                out.event("info", text=note)
            for a in followers:
                a.events("state", state="start", target=a.target.name, port=url,
                         protocol=r.protocol, rotator=a.spec.name, simulated=simulated,
                         speed="max" if virtual else clock.speed)
            follow()
    finally:
        close()
        out.close()
        if server is not None:
            server.close()
    print_results(followers, simulated)
    return 0


def print_results(followers, simulated: bool) -> None:
    """What stays on screen after the run: each pass's result and why an error is large."""
    from tracker.tracking import describe_result

    for a in followers:
        for i, res in enumerate(a.results, 1):
            print((f"{a.label}: " if a.label else "") + f"pass {i}: "
                  + describe_result(res, a.spec).replace(" commands,", " commands sent,", 1)
                  + (" (simulated)" if simulated else ""))
            if res.cause:
                print(f"  {res.cause}")


def _one_antenna(r: _Run, url: str, clock: Clock, timer, log, banner: str, tty: bool):
    """One antenna: its follower, the UI (a live panel on a terminal, else plain lines),
    the session's all-stop, the flow and the clean-up."""
    from tracker.tracking import PassFollower, describe_pass
    from tracker.trackui import Fanout, PlainLines, RichPanel

    # The panel keeps the simulation's notes (replayed date, element age) in its header.
    ui = RichPanel(clock, f"tracker track {r.targets[0].name}", banner,
                   header=tuple(r.notes)) if tty else PlainLines(clock)
    out = Fanout(ui, log)

    def show_next(p) -> None:
        if isinstance(ui, RichPanel):
            ui.next_pass = describe_pass(p) if p is not None else "none in the next days"

    a = PassFollower(r.targets[0], _opener(r, url, clock, out), r.specs[0], r.station, clock,
                     r.settings[0], events=out.event, on_status=out.status, first=r.firsts[0],
                     demo_time=timer, on_next_pass=show_next)
    return [a], out, a.stop, partial(a.run, r.args.passes), a.close


def _two_antennas(r: _Run, url: str, clock: Clock, timer, log, _banner: str, _tty: bool):
    """Two antennas on one AZ/AZ port: a follower each on the shared interface, plain lines
    prefixed ant1/ant2 (on a terminal too), ``S`` as the session's all-stop."""
    from tracker.tracking import PassFollower, SharedAzAz, follow_together
    from tracker.trackui import AntennaOut, Fanout, PlainLines

    shared = SharedAzAz(_opener(r, url, clock, None))
    out = Fanout(PlainLines(clock), log)   # run-wide lines and records (no antenna)
    lock = threading.Lock()
    followers = []
    for n, target, spec, settings, first in zip(r.numbers, r.targets, r.specs, r.settings,
                                                r.firsts, strict=True):
        a = PassFollower(target, partial(shared.axis, n), spec, r.station, clock, settings,
                         antenna=n, first=first, demo_time=timer)
        sink = AntennaOut(n, a.label, clock, log, lock)
        a.events, a.on_status = sink.event, sink.status
        followers.append(a)

    def close() -> None:
        for a in followers:
            a.close()
        shared.close()
    return (followers, out, partial(shared.session_stop, out.event),
            partial(follow_together, followers, shared, r.args.passes, out.event), close)
