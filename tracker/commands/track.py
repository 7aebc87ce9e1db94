"""``tracker track TARGET``: follow passes live on a rotator, or on the built-in emulator.

Without ``--port`` (and no ``[tracking] port`` in the config) this is a demo: the built-in
emulator of ``--protocol`` (GS-232B with a G-5500 by default; the Rotor-EZ, DCU-1, SAK-232 and
AZ/AZ emulators with their own azimuth-only rotator unless ``--rotator`` names one) runs
in-process on a simulated clock that starts shortly before the target's next pass and runs
``--speed`` times faster, so a whole pass shows in about a minute. It says so plainly. With
``--port`` everything runs in real time on the real rotator.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
from datetime import datetime, timedelta, timezone

from tracker.clock import SimClock
from tracker.commands._common import (
    add_station_args,
    add_target_args,
    add_time_args,
    config_from_args,
    parse_utc,
    station_from_args,
    target_from_args,
)
from tracker.errors import ConfigError, TargetError

DEMO_SECONDS = 60.0        # a whole demo pass in about this much wall time
STALE_ELEMENTS_DAYS = 14.0  # older elements: the demo replays a pass near their epoch
PASS_SEARCH_DAYS = 3.0
PAD_S = 60.0
# Controllers that cannot report their position: the loop runs them on an estimate.
OPEN_LOOP_PROTOCOLS = ("dcu1", "sak232")
AZ_ONLY_PROTOCOLS = ("rotorez", "dcu1", "sak232", "gs232b-azaz", "gs232b-azaz2")
# --protocol -> the emulator the demo (no --port) serves it with, when not a GS-232 profile
DEMO_EMULATORS = {"rotorez": "rotorez", "dcu1": "dcu1", "sak232": "sak232",
                  "gs232b-azaz": "gs232b-azaz", "gs232b-azaz2": "gs232b-azaz"}


def register(sub) -> None:
    p = sub.add_parser(
        "track", help="track a target live (built-in emulator demo without --port)",
        description="Follow the next pass(es) of TARGET with the rotator: pre-position, "
                    "deadband moves aimed ahead of the target, read-back every cycle, "
                    "reconnect on port loss, park after the pass. Without --port the "
                    "built-in emulator of --protocol (default GS-232B with a G-5500) runs a "
                    "simulated pass.")
    p.add_argument("target", help='satellite name or NORAD id (e.g. "ISS (ZARYA)"), Sun, Moon')
    p.add_argument("--port", help="serial port or pyserial URL of the controller "
                                  "(/dev/ttyUSB0, COM3, socket://host:port); default: the "
                                  "[tracking] port of the config, else the built-in emulator")
    p.add_argument("--protocol",
                   help="controller protocol: gs232b (default), gs232b-manual, gs232a, gs23, "
                        "k3ng, rotorez, dcu1, sak232, gs232b-azaz (antenna 1), gs232b-azaz2 "
                        "(antenna 2), rotctld (--port host:port)")
    p.add_argument("--baud", type=int, help="baud rate (default: the protocol's)")
    p.add_argument("--rotator", help="rotator preset or [rotator.NAME] (default G-5500)")
    p.add_argument("--passes", type=int, default=1, metavar="N",
                   help="passes to track in a row, re-planning from the real antenna "
                        "position between them; 0 = until Ctrl-C (default 1)")
    p.add_argument("--speed", type=float, metavar="F",
                   help="simulation speed factor (emulator demo, or with --at); default so "
                        "a pass shows in about a minute")
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
                   help="timestamped lines instead of the live panel")
    add_station_args(p)
    add_target_args(p)
    add_time_args(p)
    p.set_defaults(func=run)


def _start_time(args, target, demo: bool) -> tuple[datetime, str]:
    """Where the search for the next pass starts, and a note if the demo moved it."""
    if args.at:
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


def run(args: argparse.Namespace) -> int:
    from tracker.planner import plan_pass
    from tracker.protocols import open_driver
    from tracker.stream import Link, TrackCore, run_pass
    from tracker.trackui import Fanout, JsonLinesLog, PlainLines, RichPanel

    if args.passes < 0:
        raise ConfigError(f"--passes {args.passes} is invalid; use 1 or more, or 0 for "
                          f"'until Ctrl-C'")
    if args.speed is not None and not (0 < args.speed <= 1000):
        raise ConfigError(f"--speed {args.speed} is invalid; allowed: > 0 to 1000")
    config = config_from_args(args)
    tr = config.tracking
    port = args.port or tr.get("port")
    protocol = args.protocol or tr.get("protocol") or "gs232b"
    demo = not port
    if demo and protocol.lower() == "rotctld":
        raise ConfigError("--protocol rotctld needs --port HOST:PORT of a running rotctld "
                          "(e.g. rotctld -m 1 for Hamlib's dummy rotator)")
    emulator = DEMO_EMULATORS.get(protocol.lower()) if demo else None
    station = station_from_args(args)
    spec = config.rotator(args.rotator)
    target = target_from_args(args.target, args)
    if emulator and not (args.rotator or tr.get("rotator")):
        spec = _demo_spec(emulator)
    if protocol.lower() in AZ_ONLY_PROTOCOLS and spec.has_elevation:
        raise ConfigError(f"protocol {protocol} drives an azimuth-only rotator, but rotator "
                          f"{spec.name} has elevation; pass --rotator with an azimuth-only "
                          f"one (e.g. G-400, or a [rotator.NAME] without el_max_deg)")
    settings = _settings(args, config, spec)

    start, note = _start_time(args, target, demo)
    first = _next_pass(target, station, start.timestamp())
    simulated = demo or bool(args.at)
    if simulated:
        span = first.los.timestamp() - max(first.aos.timestamp() - 120.0, start.timestamp())
        speed = args.speed or max(1.0, round(span / DEMO_SECONDS))
        if demo:
            if speed <= 0:
                raise ConfigError(f"--speed must be > 0, got {speed}")
            clock = SimClock(max(start, first.aos - timedelta(seconds=150)), speed)
            clock.pause()   # until the first pass is planned
        else:
            clock = SimClock(start, speed)
    else:
        from tracker.clock import SystemClock

        if args.speed is not None:
            raise ConfigError("--speed needs the built-in emulator (no --port) or --at; a "
                              "real rotator runs in real time")
        clock = SystemClock()

    server = None
    if demo:
        from tracker.emulator import Gs232Controller, serve_tcp
        from tracker.protocols.gs232 import PROFILES

        if emulator:
            from tracker.emulator.rotorez_controller import make_other_controller

            controller = make_other_controller(emulator, clock, spec)
        else:
            emulator = protocol.lower() if protocol.lower() in PROFILES else "gs232b"
            controller = Gs232Controller(emulator, spec, clock=clock)
        server = serve_tcp(controller)
        url = server.url
    else:
        url = port

    def connect():
        kw = {"has_elevation": spec.has_elevation,
              "az_max_deg": 450.0 if spec.az_span_deg > 360 and not spec.controller_maps_south
              else 360.0,
              "el_max_deg": spec.el_max_deg or 90.0}
        if args.baud or tr.get("baudrate"):
            kw["baudrate"] = args.baud or tr.get("baudrate")
        if protocol in OPEN_LOOP_PROTOCOLS:
            # No position query: the driver estimates the antenna with the rotator's motor
            # model, which must run on the loop's (possibly simulated) clock. Closed-loop
            # drivers keep wall-clock read timeouts.
            kw["clock"] = clock
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
    sinks = []
    banner = ""
    if demo:
        banner = (f"SIMULATION: built-in {emulator} emulator with a {spec.name} at "
                  f"{clock.speed:g}x speed; no real rotator moves. Use --port to drive one.")
    tty = sys.stdout.isatty() and not args.plain
    title = f"tracker track {target.name}"
    if tty:
        ui = RichPanel(clock, title, banner)
    else:
        ui = PlainLines(clock)
    sinks.append(ui)
    log = JsonLinesLog(args.log, clock) if args.log else None
    sinks.append(log)
    out = Fanout(*sinks)

    def on_term(signum, frame):
        raise KeyboardInterrupt   # same path as Ctrl-C: all-stop in run_pass's finally

    old_term = signal.signal(signal.SIGTERM, on_term)
    summaries = []
    link = Link(connect, spec)
    try:
        if banner and not tty:
            out.event("info", text=banner)
        if note:
            out.event("info", text=note)
        out.event("state", state="start", target=target.name, port=url, protocol=protocol,
                  rotator=spec.name, simulated=simulated, speed=clock.speed)
        n = 0
        pas = first
        while args.passes == 0 or n < args.passes:
            # Re-plan from the real antenna position (read back now, not assumed).
            link.events = out.event
            az, el = link.position()
            if demo:
                clock.pause()
            current = _mech_guess(spec, az, el)
            track = pas.track(step_s=1.0, pad_s=PAD_S)
            plan = plan_pass(track, spec, station, current=current,
                             park=settings.park_after_pass)
            try:
                nxt = _next_pass(target, station, pas.los.timestamp() + 60.0)
            except TargetError:
                nxt = None
            if isinstance(ui, RichPanel):
                ui.next_pass = _describe(nxt) if nxt is not None else "none in the next days"
            out.event("info", text=f"pass {n + 1}: {target.name} {_describe(pas)}; mode "
                                   f"{plan.mode}: {plan.reason}")
            out.event("state", state="plan", mode=plan.mode,
                      predicted_max_error_deg=round(plan.max_error_deg, 2),
                      aos=pas.aos.isoformat(), los=pas.los.isoformat())
            if demo:
                lead = min(plan.preposition_t_s, pas.aos.timestamp() - 120.0) - 10.0
                gap = lead - clock.timestamp()
                if gap > 0 and n > 0:
                    out.event("info", text=f"skipping {gap / 60:.0f} min of simulated "
                                           f"idle time to the next pass")
                    clock.skip(gap)
                clock.resume()
            core = TrackCore(plan, track, spec, station, settings)
            res = run_pass(core, link, clock, on_status=out.status, events=out.event)
            err = res.errors_deg
            p99 = sorted(err)[max(0, math.ceil(0.99 * len(err)) - 1)] if err else float("nan")
            summaries.append(res)
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
    finally:
        signal.signal(signal.SIGTERM, old_term)
        link.drop()
        out.close()
        if server is not None:
            server.close()
    for i, res in enumerate(summaries, 1):
        print(f"pass {i}: {res.commands} commands sent, max pointing error "
              f"{res.max_error_deg:.1f} deg, {res.reconnects} reconnects"
              + (" (simulated)" if simulated else ""))
    return 0


def _demo_spec(emulator: str):
    """The rotator the demo emulator of a non-GS-232 protocol drives by default."""
    from tracker.emulator.azaz_controller import AZ_360
    from tracker.emulator.rotorez_controller import HAM_IV
    from tracker.emulator.sak232_controller import ZELPRO_RAU

    return {"rotorez": HAM_IV, "dcu1": HAM_IV, "sak232": ZELPRO_RAU,
            "gs232b-azaz": AZ_360}[emulator]


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
