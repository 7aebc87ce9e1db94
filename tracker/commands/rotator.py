"""``tracker rotator``: a small rotctl-like tool to check wiring on real ports and emulators."""

from __future__ import annotations

import argparse

from tracker.commands._common import check_baud_arg

AZAZ_PROTOCOLS = ("gs232b-azaz", "gs232b-azaz2")


def register(sub) -> None:
    p = sub.add_parser(
        "rotator", help="talk to a rotator controller: position, goto, stop, park, raw, "
                        "sync/unsync (AZ/AZ)",
        description="Send one command to a controller on any pyserial URL (/dev/ttyUSB0, COM3, "
                    "socket://host:port, /dev/pts/N of 'tracker emulate').")
    p.add_argument("--port", required=True, help="serial device or pyserial URL")
    p.add_argument("--protocol", default="gs232b",
                   help="gs232b (default), gs232b-manual, gs232a, gs23, k3ng, rotorez, dcu1, "
                        "sak232, gs232b-azaz (antenna 1), gs232b-azaz2 (antenna 2), rotctld "
                        "(--port host:port)")
    p.add_argument("--baud", type=int, default=None, help="baud rate (default: profile's)")
    p.add_argument("--timeout", type=float, default=1.0, help="reply timeout in seconds")
    p.add_argument("--az-only", action="store_true", help="azimuth-only rotator (C / M)")
    p.add_argument("--autobaud", action="store_true",
                   help="GS-232B power-up: send CR until 'Connect OK' first")
    p.add_argument("--park-az", type=float, default=0.0, help="park azimuth (default 0)")
    p.add_argument("--park-el", type=float, default=0.0, help="park elevation (default 0)")
    act = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    act.add_parser("position", help="print az el as the controller reports them")
    g = act.add_parser("goto", help="start turning to AZ [EL] (wire degrees) and return")
    g.add_argument("az", type=float)
    g.add_argument("el", type=float, nargs="?")
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

    from tracker.errors import ConfigError
    from tracker.protocols import open_driver

    # A NaN/infinite timeout would make every deadline check false: refuse it here, once,
    # for every protocol.
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise ConfigError(f"--timeout {args.timeout} is invalid; use a number of seconds > 0")
    check_baud_arg(args)
    if args.action == "raw" and not args.cmd.isascii():
        raise ConfigError(f"raw command {args.cmd!r} is not ASCII; controllers take ASCII "
                          f"command lines such as C2")
    if args.action in ("sync", "unsync") and args.protocol.lower() not in AZAZ_PROTOCOLS:
        raise ConfigError(f"{args.action} is a GS-232B-AZ/AZ command; use --protocol "
                          f"gs232b-azaz (got {args.protocol})")
    if args.action == "sync" and not (math.isfinite(args.offset_deg)
                                      and 0 <= round(args.offset_deg) <= 360):
        raise ConfigError(f"sync offset {args.offset_deg:g} is invalid; use 0..360 degrees "
                          f"(antenna 2 = antenna 1 + offset, mod 360)")
    kw = {"timeout_s": args.timeout, "autobaud": args.autobaud,
          "has_elevation": not args.az_only}
    if args.baud:
        kw["baudrate"] = args.baud
    with open_driver(args.port, args.protocol, **kw) as drv:
        # A rotctl-like tool leaves a started move running; only "stop" stops.
        drv.stop_on_exit = False
        if args.action == "position":
            if not drv.capabilities.has_position_query:
                raise ConfigError(f"protocol {args.protocol} has no position query; the "
                                  f"tracker runs it open loop on the motor model's estimate")
            az, el = drv.position()
            print(f"{az:g}" if el is None else f"{az:g} {el:g}")
        elif args.action == "goto":
            drv.goto(args.az, args.el)
        elif args.action == "park":
            drv.goto(args.park_az, None if args.az_only else args.park_el)
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
    return 0
