"""``tracker serve-rotctld``: a Hamlib-compatible control port (rotctld protocol) in front of
any controller, every move checked against the rotator's limits and the horizon mask.

Without ``--port`` it serves the built-in emulator of ``--protocol`` in-process on the real
clock. The server itself is :class:`tracker.service.rotctld_server.RotctldServer`; this module
parses the flags and wires it up.
"""

from __future__ import annotations

import argparse
import sys

from tracker.commands._common import (
    add_rotator_args,
    add_station_args,
    check_baud_arg,
    config_from_args,
    protocol_help,
    rotator_from_args,
    station_from_args,
)


def register(sub) -> None:
    p = sub.add_parser(
        "serve-rotctld",
        help="serve a Hamlib rotctld-compatible control port in front of a controller",
        description="Listen for rotctld clients (gpredict, rotctl -m 2 -r HOST:PORT, ...) and "
                    "drive the controller for them; every move is checked against the "
                    "rotator's limits and the horizon mask, and watched for stalls. Runs "
                    "until Ctrl-C or SIGTERM, then sends all-stop.")
    p.add_argument("--port", default=None,
                   help="serial device or pyserial URL of the controller (default: the "
                        "built-in emulator of --protocol, on the real clock)")
    p.add_argument("--protocol", default="gs232b", help=protocol_help())
    p.add_argument("--baud", type=int, default=None, help="baud rate (default: profile's)")
    p.add_argument("--listen", default="127.0.0.1:4533", metavar="HOST:PORT",
                   help="address to listen on (default 127.0.0.1:4533; port 0: any free "
                        "port). Anyone who can reach it can move the antenna")
    p.add_argument("--log", metavar="FILE", default=None,
                   help="also write the events (refusals, stalls, ...) as JSON lines to FILE")
    add_rotator_args(p)
    add_station_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tracker.clock import SystemClock
    from tracker.controllers import controller
    from tracker.errors import ConfigError
    from tracker.service.rotctld_server import RotctldServer, is_loopback, listen_address
    from tracker.session import ControllerSession

    check_baud_arg(args)
    host, port = listen_address(args.listen)
    entry = controller(args.protocol)
    if not args.port and entry.emulator is None:
        raise ConfigError(f"--protocol {args.protocol} needs --port {entry.port_hint}")
    config = config_from_args(args)
    spec = rotator_from_args(args, args.rotator or config.tracking.get("rotator")
                             or entry.default_rotator)
    if not entry.has_elevation and spec.has_elevation:
        raise ConfigError(f"protocol {args.protocol} drives an azimuth-only rotator, but "
                          f"rotator {spec.name} has elevation; pass --rotator with an "
                          f"azimuth-only one (e.g. G-400)")
    station = station_from_args(args, quiet=True)
    clock = SystemClock()
    log = None
    if args.log:
        from tracker.trackui import JsonLinesLog
        log = JsonLinesLog(args.log, clock)
    connect, url = _connector(args, entry, spec, clock)
    connect().close()           # a wrong --port ends the run here, before anyone listens

    def event(kind: str, **data: object) -> None:
        print(data.get("text", kind), flush=True)
        if log is not None:
            log.event(kind, **data)

    if not is_loopback(host):
        print(f"tracker: warning: listening on {host}, not on this machine only: anyone on "
              f"that network can move the antenna", file=sys.stderr, flush=True)
    server = RotctldServer(connect, spec, station=station, clock=clock, host=host, port=port,
                           events=event)
    server.start()
    session = ControllerSession(server.all_stop, stop_at_end=False,
                                on_stop_failed=lambda why: print(
                                    f"tracker: warning: {why}; stop the rotator by hand",
                                    file=sys.stderr, flush=True))
    try:
        with session:
            server.hand_over()
            # Said once the signals end in all-stop: a client may drive from now on.
            print(f"rotctld control port on {server.listen}: {args.protocol} on {url}, "
                  f"rotator {spec.name}; Ctrl-C stops (all-stop)", flush=True)
            while True:
                clock.sleep(3600.0)
    except KeyboardInterrupt as e:
        # A signal is how a server ends: the session sent all-stop (or warned that it could
        # not), so this is a normal end.
        print(f"control port closed ({getattr(e, 'signame', 'interrupted')})", flush=True)
        return 0 if session.stopped else 2
    finally:
        server.close()
        if log is not None:
            log.close()
    return 0


def _connector(args: argparse.Namespace, entry, spec, clock):
    """(the driver's connect callable, the controller's URL): ``--port``, else the built-in
    emulator of the protocol in-process on ``clock`` (said in one line)."""
    from functools import partial

    from tracker.protocols import open_driver
    from tracker.session import driver_limits

    url = args.port
    if not url:
        from tracker.emulator.factory import make_emulator
        from tracker.emulator.virtual import Bench

        url = Bench(make_emulator(entry.name, clock, spec)).url
        print(f"SIMULATION: built-in {entry.name} emulator with a {spec.name} on the real "
              f"clock; no real rotator moves. Use --port to drive one.", flush=True)
    kw = {**driver_limits(spec), "clock": clock}
    if args.baud:
        kw["baudrate"] = args.baud
    if entry.open_loop:
        kw["spec"] = spec       # its position is the motor model's estimate
    return partial(open_driver, url, args.protocol, **kw), url
