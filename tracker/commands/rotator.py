"""``tracker rotator``: a small rotctl-like tool to check wiring on real ports and emulators."""

from __future__ import annotations

import argparse
import sys

from tracker.commands._common import (
    add_rotator_args,
    add_station_args,
    check_baud_arg,
    protocol_help,
    rotator_from_args,
    station_from_args,
)


def register(sub) -> None:
    p = sub.add_parser(
        "rotator", help="talk to a rotator controller: position, goto, stop, park, raw, "
                        "sync/unsync (AZ/AZ)",
        description="Send one command to a controller on any pyserial URL (/dev/ttyUSB0, COM3, "
                    "socket://host:port, /dev/pts/N of 'tracker emulate').")
    p.add_argument("--port", required=True, help="serial device or pyserial URL")
    p.add_argument("--protocol", default="gs232b",
                   help=protocol_help())
    p.add_argument("--baud", type=int, default=None, help="baud rate (default: profile's)")
    p.add_argument("--timeout", type=float, default=1.0, help="reply timeout in seconds")
    p.add_argument("--az-only", action="store_true", help="azimuth-only rotator (C / M)")
    p.add_argument("--autobaud", action="store_true",
                   help="GS-232B power-up: send CR until 'Connect OK' first")
    p.add_argument("--park-az", type=float, default=None, metavar="DEG",
                   help="park azimuth in wire degrees like goto (default: the rotator's "
                        "park_az_deg)")
    p.add_argument("--park-el", type=float, default=None, metavar="DEG",
                   help="park elevation (default: the rotator's park_el_deg, raised to the "
                        "horizon mask there)")
    p.add_argument("--ignore-limits", action="store_true",
                   help="MAINTENANCE ONLY: do not check goto/park against the rotator limits "
                        "and the horizon mask (the controller's own range still applies); "
                        "also needed by raw, whose bytes the guard cannot check")
    add_rotator_args(p)
    add_station_args(p)
    act = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    act.add_parser("position", help="print az el as the controller reports them")
    g = act.add_parser(
        "goto", help="start turning to AZ [EL] and return; refused outside the rotator's "
                     "limits or below the horizon mask",
        description="AZ and EL are wire degrees, as 'position' prints them: the mechanical "
                    "angle from the rotator's CCW stop (0 to its span, e.g. 0-450 for a "
                    "G-5500), or a true bearing for a controller that maps a south-centred "
                    "scale itself. Without EL an az/el rotator keeps its elevation.")
    g.add_argument("az", type=float, help="azimuth, wire degrees")
    g.add_argument("el", type=float, nargs="?", help="elevation, degrees")
    act.add_parser("stop", help="all stop")
    act.add_parser("park", help="turn to the park position")
    r = act.add_parser("raw", help="send one command line, print the reply bytes")
    r.add_argument("cmd")
    y = act.add_parser("sync", help="GS-232B-AZ/AZ: antenna 2 follows antenna 1 + OFFSET_DEG "
                                    "(Y / Ynnn) until 'unsync'")
    y.add_argument("offset_deg", type=float, metavar="OFFSET_DEG",
                   help="azimuth 2 = azimuth 1 + this, mod 360 (0..360, whole degrees)")
    act.add_parser("unsync", help="GS-232B-AZ/AZ: cancel sync (Y999); antenna 2 stays "
                                  "where it is and takes its own commands again")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import math

    from tracker.controllers import controller
    from tracker.errors import ConfigError
    from tracker.protocols import open_driver
    from tracker.session import ControllerSession, EffectiveLimits, driver_limits

    # A NaN/infinite timeout would make every deadline check false: refuse it here, once,
    # for every protocol.
    if not (math.isfinite(args.timeout) and 0 < args.timeout <= 3600):
        raise ConfigError(f"--timeout {args.timeout:g} is invalid; use a number of seconds "
                          f"above 0 and at most 3600")
    check_baud_arg(args)
    if args.action == "raw" and not args.cmd.isascii():
        raise ConfigError(f"raw command {args.cmd!r} is not ASCII; controllers take ASCII "
                          f"command lines such as C2")
    if args.action == "raw" and not args.ignore_limits:
        # A raw line may be a move (W400 170) that no limit or mask check sees.
        raise ConfigError("raw sends a command line unchecked, and it may move the rotator "
                          "past its limits or below the mask; add --ignore-limits to send it "
                          "(maintenance), or use goto/park/position")
    if args.action in ("sync", "unsync") and not controller(args.protocol).dual_azimuth:
        raise ConfigError(f"{args.action} is a GS-232B-AZ/AZ command; use --protocol "
                          f"gs232b-azaz (got {args.protocol})")
    if args.action == "sync" and not (math.isfinite(args.offset_deg)
                                      and args.offset_deg == int(args.offset_deg)
                                      and 0 <= args.offset_deg <= 360):
        raise ConfigError(f"sync offset {args.offset_deg:g} is invalid; use 0..360 degrees "
                          f"(whole degrees: antenna 2 = antenna 1 + offset, mod 360)")
    spec = rotator_from_args(args)
    station = station_from_args(args, quiet=True)
    if args.ignore_limits and args.action in ("goto", "park", "raw"):
        print("tracker: warning: --ignore-limits: this command is NOT checked against the "
              f"limits of rotator {spec.name} or the horizon mask; make sure nothing is in "
              "the way", file=sys.stderr)
    kw = {"timeout_s": args.timeout, "autobaud": args.autobaud,
          **driver_limits(spec, has_elevation=not args.az_only)}
    if args.baud:
        kw["baudrate"] = args.baud
    with open_driver(args.port, args.protocol, **kw) as drv:
        # A rotctl-like tool leaves a started move running; only "stop" stops. The session
        # stops on a signal or an error, and refuses moves outside the effective limits.
        drv.stop_on_exit = False
        limits = EffectiveLimits.of(spec, station, drv.capabilities)
        with ControllerSession(drv.stop, stop_at_end=False, limits=limits,
                               ignore_limits=args.ignore_limits,
                               on_stop_failed=_stop_failed_for(args.action)) as session:
            _act(args, drv, session, spec, station)
    return 0


def _stop_failed_for(action: str):
    """What to say when the session's all-stop fails. A position query moved nothing, and
    the error line already says the port is gone: one line is enough there."""
    def warn(why: str) -> None:
        if action != "position":
            print(f"tracker: warning: {why}; stop the rotator by hand", file=sys.stderr)
    return warn


def _act(args: argparse.Namespace, drv, session, spec, station) -> None:
    from tracker.errors import ConfigError

    if args.action == "position":
        if not drv.capabilities.has_position_query:
            raise ConfigError(f"protocol {args.protocol} has no position query; the "
                              f"tracker runs it open loop on the motor model's estimate")
        az, el = drv.position()
        print(f"{az:g}" if el is None else f"{az:g} {el:g}")
    elif args.action == "goto":
        _move(drv, session, args.az, args.el)
    elif args.action == "park":
        az, el = _park_target(args, session, spec, station)
        _move(drv, session, az, el)
    elif args.action == "stop":
        drv.stop()
    elif args.action == "raw":
        print(repr(drv.raw(args.cmd)))
    elif args.action == "sync":
        iface = getattr(drv, "parent", drv)        # gs232b-azaz2 is antenna 2's view
        iface.sync(args.offset_deg)
        print(f"antenna 2 follows antenna 1 + {iface.sync_offset:03d} deg; drive antenna "
              f"1 (--protocol gs232b-azaz), 'unsync' cancels")
    elif args.action == "unsync":
        getattr(drv, "parent", drv).unsync()
        print("sync cancelled: antenna 2 takes its own commands again")


def _park_target(args: argparse.Namespace, session, spec, station
                 ) -> tuple[float, float | None]:
    """The park position in wire degrees: the rotator's (raised to the mask, as after a
    pass), or --park-az / --park-el."""
    from tracker.planner import park_position

    park_m, park_el = park_position(spec, station)
    az = spec.frame.wire_of(park_m) if args.park_az is None else args.park_az
    el = park_el if args.park_el is None else args.park_el
    limits = session.limits
    return az, (el if limits is None or limits.has_elevation else None)


def _move(drv, session, az_deg: float, el_deg: float | None) -> None:
    """Check the move against the session's limits and mask, then start it."""
    from tracker.errors import ConfigError

    limits = session.limits
    if el_deg is None and limits is not None and limits.has_elevation \
            and not session.ignore_limits:
        # Azimuth alone keeps the elevation: check the mask at the elevation read back.
        if not drv.capabilities.has_position_query:
            raise ConfigError("this controller cannot report its elevation; give AZ EL so "
                              "the move can be checked against the horizon mask")
        _az, el_now = drv.position()
        session.check_move(az_deg, el_now)
    else:
        session.check_move(az_deg, el_deg)
    drv.goto(az_deg, el_deg)
