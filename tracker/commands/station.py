"""``tracker station run``: run the station unattended — schedule, track, refresh, report.

The station, rotator, controller port and the ``[schedule]`` section come from the config
file (flags override them). ``--simulate`` runs the same service on the built-in emulator of
the protocol, on virtual time (``--speed`` times real time, or ``max``), for ``--hours``, and
ends with the report; with no ``[schedule]`` in the config it simulates a small default one.

Signals: SIGINT and SIGTERM send all-stop and end the run cleanly (exit 0, report printed);
SIGHUP re-reads the configuration between passes (a pass under way is finished first).
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
from datetime import datetime, timezone
from functools import partial
from pathlib import Path
from typing import Any

from tracker.commands._common import (
    add_rotator_args,
    add_station_args,
    add_target_args,
    catalog_from_args,
    check_baud_arg,
    config_from_args,
    parse_utc,
    protocol_help,
    rotator_from_args,
    speed_arg,
    station_from_args,
    stream_settings,
)
from tracker.errors import ConfigError

DEFAULT_STATUS_PORT = 8073
DEFAULT_CONTROL_PORT = 4533
MAX_HOURS = 24 * 366
SPEED_RANGE = (0.01, 100_000.0)   # slower than this, a nap's real wait overflows the OS's


def register(sub) -> None:
    p = sub.add_parser("station", help="run a ground station unattended (schedule, track, "
                                       "refresh elements, status page, control port)",
                       description="Station mode: run the [schedule] of the config file "
                                   "pass after pass, unattended.")
    actions = p.add_subparsers(dest="station_command", metavar="ACTION", required=True)
    r = actions.add_parser(
        "run", help="run the schedule (--simulate: on the built-in emulator)",
        description="Keep a rolling 24 h schedule of the wanted passes (the [schedule] "
                    "section of the config), refresh elements on its own, track each pass "
                    "live or as a step table, park in between, hand the rotator to "
                    "rotctld clients (Gpredict, rotctl) between passes, and show it all on a "
                    "status page. --simulate runs it on the built-in emulator.")
    r.add_argument("--simulate", action="store_true",
                   help="no rotator: the built-in emulator of --protocol, on simulated time "
                        "(see --speed, --hours, --at); ends with the report")
    r.add_argument("--hours", type=float, metavar="H",
                   help="run this many (simulated) hours, then report (default: until "
                        "stopped; 24 with --simulate)")
    r.add_argument("--speed", type=speed_arg, metavar="F",
                   help="with --simulate: simulated seconds per real second (default 600), "
                        "or 'max' for no waiting at all")
    r.add_argument("--at", metavar="UTC",
                   help="with --simulate: start the simulated day here (default: now, or "
                        "the element epoch when the elements are stale)")
    r.add_argument("--port", help="serial port or pyserial URL of the controller (default: "
                                  "the [tracking] port of the config)")
    r.add_argument("--protocol", help=protocol_help())
    r.add_argument("--baud", type=int, help="baud rate (default: the protocol's)")
    add_rotator_args(r)
    r.add_argument("--state", metavar="FILE",
                   help="state file: each pass's outcome, so a restart picks up where it was "
                        "(default: station-state.json in the user state folder; none with "
                        "--simulate)")
    r.add_argument("--pass-log", metavar="FILE",
                   help="JSON lines, one per pass, rotated at 5 MB (default: passes.jsonl "
                        "beside the state file)")
    r.add_argument("--plot", metavar="PNG",
                   help="at the end, write the run's timeline: tracked passes solid, the "
                        "others hollow (needs matplotlib: the [plot] extra)")
    r.add_argument("--force", action="store_true", help="let --plot replace a file")
    r.add_argument("--listen", metavar="ADDR", default="127.0.0.1",
                   help="address the status page and control port listen on (default "
                        "127.0.0.1; anything else lets others on that network see the page "
                        "and MOVE THE ANTENNA)")
    r.add_argument("--status-port", type=int, metavar="N",
                   help=f"status page port (default {DEFAULT_STATUS_PORT}; off with "
                        f"--simulate unless given)")
    r.add_argument("--no-status", action="store_true", help="no status page")
    r.add_argument("--control-port", type=int, metavar="N",
                   help=f"rotctld-compatible control port (default {DEFAULT_CONTROL_PORT}; "
                        f"not with --simulate)")
    r.add_argument("--no-control", action="store_true", help="no control port")
    add_station_args(r)
    add_target_args(r)
    r.set_defaults(func=run)


def _check_args(args: argparse.Namespace) -> None:
    check_baud_arg(args)
    if args.hours is not None and not (0 < args.hours <= MAX_HOURS):
        raise ConfigError(f"--hours {args.hours:g} is invalid; give more than 0 and at most "
                          f"{MAX_HOURS}")
    low, high = SPEED_RANGE
    if args.speed is not None and args.speed != math.inf and not (low <= args.speed <= high):
        raise ConfigError(f"--speed {args.speed:g} is invalid; use a number from {low:g} to "
                          f"{high:g}, or max")
    if not args.simulate:
        for flag, value in (("--speed", args.speed), ("--at", args.at)):
            if value is not None:
                raise ConfigError(f"{flag} needs --simulate; a real station runs in real time")
    elif args.control_port is not None:
        raise ConfigError("--control-port needs a real controller; --simulate drives the "
                          "built-in emulator, which outside programs cannot reach")
    for flag, port in (("--status-port", args.status_port),
                       ("--control-port", args.control_port)):
        if port is not None and not (0 < port < 65536):
            raise ConfigError(f"{flag} {port} is invalid; use 1 to 65535")


def _schedule_settings(args: argparse.Namespace, config: Any) -> Any:
    from tracker.service.simulate import simulation_schedule

    settings = getattr(config, "schedule", None)
    if settings is not None:
        return settings
    if args.simulate:
        return simulation_schedule()
    raise ConfigError("the config file has no [schedule] section, so the station has nothing "
                      "to track; add one (targets = { \"ISS (ZARYA)\" = 3 } ...; see "
                      "docs/station.md), or try --simulate")


def _state_paths(args: argparse.Namespace) -> tuple[Path | None, Path | None]:
    if args.simulate and not args.state:
        return None, Path(args.pass_log).expanduser() if args.pass_log else None
    if args.state:
        state = Path(args.state).expanduser()
    else:
        from platformdirs import user_state_dir

        state = Path(user_state_dir("tracker")) / "station-state.json"
    log = Path(args.pass_log).expanduser() if args.pass_log else state.with_name("passes.jsonl")
    for what, path in (("--state", state), ("--pass-log", log)):
        if path.exists() and not path.is_file():
            raise ConfigError(f"{what} {path} is not a regular file; give a file path")
    return state, log


def _simulation_start(args: argparse.Namespace, catalog: Any, settings: Any) -> tuple[datetime,
                                                                                         str]:
    """Where a simulated day starts: --at, else now — or the element epoch when the
    elements are stale (their passes that far out are fiction), said in a note."""
    from tracker.targets import resolve_target
    from tracker.tracking import demo_start

    if args.at is not None:
        return parse_utc(args.at), ""
    now = datetime.now(timezone.utc)  # CLI boundary: the only place the real time is read
    first = next(iter(settings.targets), None)
    if first is None:
        return now, ""
    return demo_start(resolve_target(str(first), catalog), now)


def _controller(args: argparse.Namespace, config: Any) -> tuple[Any, str | None, Any]:
    """The controller's registry entry, its port (None: the simulation's emulator) and the
    rotator behind it."""
    from tracker.controllers import controller

    tr = config.tracking
    entry = controller(args.protocol or tr.get("protocol") or "gs232b")
    port = None if args.simulate else (args.port or tr.get("port"))
    if not args.simulate and not port:
        raise ConfigError("give --port (or port in [tracking] of the config) for the "
                          "controller, or --simulate to run on the built-in emulator")
    if args.simulate and entry.emulator is None:
        raise ConfigError(f"--protocol {entry.name} has no built-in emulator to simulate on")
    if args.simulate and not (args.rotator or tr.get("rotator")):
        return entry, port, config.rotator(entry.default_rotator)
    return entry, port, rotator_from_args(args)


def _clock(args: argparse.Namespace, catalog: Any, settings: Any) -> tuple[Any, float | None,
                                                                            str]:
    """The run's clock, its length in hours (None: until stopped) and the simulation's
    banner ("" for a real station)."""
    from tracker.clock import LockstepClock, PacedClock, SystemClock

    if not args.simulate:
        return SystemClock(), args.hours, ""
    start, note = _simulation_start(args, catalog, settings)
    speed = args.speed if args.speed is not None else 600.0
    hours = args.hours if args.hours is not None else 24.0
    pace = "virtual time" if speed == math.inf else f"{speed:g}x speed"
    banner = (f"{hours:g} simulated hours from {start:%Y-%m-%d %H:%M} UTC at {pace}; no real "
              f"rotator moves." + (f"\n{note}" if note else ""))
    return (LockstepClock(start) if speed == math.inf else PacedClock(start, speed)), hours, \
        banner


def run(args: argparse.Namespace) -> int:
    from tracker.service.board import StatusBoard
    from tracker.service.records import PassLog
    from tracker.service.runner import StationService
    from tracker.service.simulate import connector, emulated

    _check_args(args)
    config = config_from_args(args)
    settings = _schedule_settings(args, config)
    entry, port, spec = _controller(args, config)
    station = station_from_args(args)
    stream = stream_settings(config, spec)
    state_path, log_path = _state_paths(args)
    if args.plot:
        from tracker.plot import check_plot_path

        check_plot_path(args.plot, force=args.force, label="--plot")  # before, not after hours
    from_files = args.simulate or bool(getattr(args, "tle", None))
    catalog = catalog_from_args(args) if from_files else None
    clock, hours, banner = _clock(args, catalog, settings)
    keeper = None if from_files else _element_keeper(settings, clock)
    board = StatusBoard(clock, station={"name": station.name, "lat_deg": station.lat_deg,
                                        "lon_deg": station.lon_deg, "alt_m": station.alt_m},
                        rotator={"name": spec.name, "protocol": entry.name,
                                 "port": port or "built-in emulator",
                                 "az_span_deg": spec.az_span_deg,
                                 "el_max_deg": spec.el_max_deg},
                        simulated=args.simulate)
    say = partial(print, flush=True)
    bench = None
    if args.simulate:
        bench, connect = emulated(entry, spec, clock)
        say(f"SIMULATION: built-in {entry.name} emulator with a {spec.name}, {banner}")
    else:
        connect = connector(str(port), entry, spec, clock,
                            args.baud or config.tracking.get("baudrate"))
    from contextlib import ExitStack

    from tracker.service.records import state_lock
    from tracker.session import route_stop_signals

    guard = _StopGuard()
    restore_signals = route_stop_signals(guard, guard.signals)
    try:
        start_s = clock.timestamp()
        with ExitStack() as held:
            if state_path is not None:    # before anything is sent: one run per state file
                held.enter_context(state_lock(state_path))
            report = _run_service(args, guard, StationService(
                station=station, spec=spec, controller=entry, connect=connect, clock=clock,
                schedule=settings, stream=stream, board=board, keeper=keeper,
                catalog=catalog, state_path=state_path,
                pass_log=PassLog(log_path) if log_path else None, say=say), hours, say)
        print(report.text())
        if args.plot:
            path = report.plot(args.plot, start_s, clock.timestamp(), force=args.force,
                               label="--plot")
            print(f"timeline: {path}")
    finally:
        if bench is not None:
            bench.close()
        restore_signals()
    return 0


def _run_service(args: argparse.Namespace, guard: _StopGuard, service: Any,
                 hours: float | None, say: Any) -> Any:
    """Start the status page and the control port, run the service, close the servers."""
    servers: list[Any] = []
    try:
        servers += [s for s in (_status_server(args, service.board, say),
                                _control_server(args, service.connect, service.spec,
                                                service.station, service.clock,
                                                service.board, say))
                    if s is not None]
        service.control = next((s for s in servers if hasattr(s, "take_back")), None)
        clock = service.clock
        until_s = clock.timestamp() + hours * 3600.0 if hours is not None else None
        return _serve(args, service, until_s, guard)
    finally:
        for server in reversed(servers):
            server.close()


class _StopGuard:
    """SIGINT and SIGTERM outside the controller session (which has its own handlers):
    before it they end the run; after it (the all-stop is sent) a second one is let pass, so
    it cannot kill the process before the servers close and the report is printed."""

    signals = tuple(s for s in (signal.SIGINT, getattr(signal, "SIGTERM", None)) if s)

    def __init__(self) -> None:
        self.session_began = False

    def __call__(self, signum: int, _frame: object) -> None:
        from tracker.session import Interrupted

        if not self.session_began:
            raise Interrupted(signum)


def _serve(args: argparse.Namespace, service: Any, until_s: float | None,
           guard: _StopGuard) -> Any:
    """Run the service inside a controller session: SIGINT/SIGTERM end it with all-stop,
    SIGHUP asks for a reload between passes."""
    from tracker.session import ControllerSession, Interrupted

    def reload() -> None:
        args._config = None
        fresh = config_from_args(args)
        service.settings = _schedule_settings(args, fresh)
        service.stream = stream_settings(fresh, service.spec)

    def on_hup(_signum: int, _frame: object) -> None:
        service.request_reload(reload)

    hup = getattr(signal, "SIGHUP", None)
    old_hup = signal.signal(hup, on_hup) if hup is not None else None
    try:
        with ControllerSession(service.all_stop, stop_at_end=False, signals=guard.signals,
                               on_stop_failed=lambda why: service.fault(
                                   f"all-stop failed: {why}")) as session:
            guard.session_began = True
            try:
                return service.run(until_s)
            except Interrupted:
                service.say(f"{session.signal or 'interrupted'}: stopping the rotator")
                raise
    except Interrupted:
        service.say("all-stop sent; the station is stopped" if session.stopped
                    else "the station is stopped (all-stop did not reach the controller)")
        return service.report
    finally:
        if hup is not None:
            signal.signal(hup, old_hup)


def _element_keeper(settings: Any, clock: Any) -> Any:
    from tle.store import TleStore
    from tracker.service.elements import ElementKeeper

    return ElementKeeper(TleStore(clock=clock), list(settings.element_sources), clock,
                         refresh_s=settings.refresh_h * 3600.0)


def _status_server(args: argparse.Namespace, board: Any, say: Any) -> Any:
    if args.no_status or (args.simulate and args.status_port is None):
        return None
    try:
        from tracker.service.web import StatusServer
    except ImportError as e:
        say(f"status page off: {e}")
        return None
    from tracker.transport import is_loopback

    port = DEFAULT_STATUS_PORT if args.status_port is None else args.status_port
    server = StatusServer(board, host=args.listen, port=port)
    server.start()
    if not is_loopback(args.listen):
        print(f"tracker: warning: the status page listens on {args.listen}: anyone on that "
              f"network can read it", file=sys.stderr)
    say(f"status page: {server.url}")
    return server


def _control_server(args: argparse.Namespace, connect: Any, spec: Any, station: Any,
                    clock: Any, board: Any, say: Any) -> Any:
    if args.no_control or args.simulate:
        return None
    from tracker.service.rotctld_server import RotctldServer
    from tracker.transport import is_loopback

    port = DEFAULT_CONTROL_PORT if args.control_port is None else args.control_port
    server = RotctldServer(connect, spec, station=station, clock=clock, host=args.listen,
                           port=port, board=board)
    server.start()
    if not is_loopback(args.listen):
        print(f"tracker: warning: the control port listens on {args.listen}: anyone on that "
              f"network can MOVE THE ANTENNA between passes", file=sys.stderr)
    say(f"control port (rotctld protocol): {args.listen}:{server.address[1]}; handed to "
        f"outside clients between passes")
    return server
