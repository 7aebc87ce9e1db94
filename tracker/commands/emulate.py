"""``tracker emulate``: run an emulated controller on a pty or a TCP port."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections.abc import Callable


def register(sub) -> None:
    p = sub.add_parser(
        "emulate", help="run a virtual rotator controller on a pty or TCP port",
        description="Serve an emulated controller (GS-232B by default) driving a simulated "
                    "rotator. Prints the port (/dev/pts/N or socket://host:port), then a live "
                    "status line. Ctrl-C, SIGTERM or SIGHUP stops it.")
    p.add_argument("--protocol", default="gs232b",
                   help="gs232b (default), or any protocol with an emulator: "
                        + ", ".join(_emulated()))
    where = p.add_mutually_exclusive_group()
    where.add_argument("--pty", action="store_true", help="serve on a new pseudo-terminal "
                       "(default)")
    where.add_argument("--tcp", type=int, metavar="PORT", help="listen on TCP PORT (0 = any)")
    p.add_argument("--bind", default="127.0.0.1", help="TCP address (default 127.0.0.1)")
    p.add_argument("--rotator", default=None,
                   help="rotator preset (default: the protocol's, G-5500 for the GS-232 family)")
    p.add_argument("--mains", type=int, default=60, choices=(50, 60), help="mains frequency")
    p.add_argument("--speed", type=float, default=1.0,
                   help="run the motors this many times faster than real time")
    p.add_argument("--az", type=float, default=None, help="initial azimuth (mechanical deg)")
    p.add_argument("--el", type=float, default=None, help="initial elevation deg")
    p.add_argument("--strict-acks", action="store_true",
                   help="send CR after every set command, as the manual says")
    p.add_argument("--one-space", action="store_true", help="C2 reply with one space")
    p.add_argument("--readback-360", action="store_true", help="report 0-359 in 450 mode")
    p.add_argument("--gs23", action="store_true",
                   help="sak232 only: also answer the GS-23 subset (Mxxx, S, C -> +0aaa) that "
                        "a logger set to 'Yaesu GS-23' sends, as the SAK-232 guide advises")
    p.add_argument("--end", choices=("stay", "clear"), default=None,
                   help="after the last table point: stay there or clear the list")
    p.add_argument("--autobaud", action="store_true",
                   help="wait for CRs and answer 'Connect OK' first (GS-232B power-up)")
    p.add_argument("--fault", action="append", default=[], metavar="SPEC",
                   help="inject a fault (repeatable), NAME[=VALUE][@START_S]: byte rates "
                        "drop=0.01, garble=0.01, duplicate=0.01 (add :in or :out for one "
                        "direction; @100+30 = from 100 s for 30 s), delay=0.2 (s per reply), "
                        "silent=30@120 (no replies for 30 s), deaf=30@120 (input ignored), "
                        "powercycle@300 (powercycle=2@300: off 2 s; tables lost; with "
                        "--autobaud, autobaud again), jam=az@60 (jam=el:30@60: for 30 s), "
                        "drift=0.5%% or drift=-200ppm (step clock), wrongside (0-359 "
                        "read-back in 450 mode), "
                        "disconnect=5@200 (close the pty or TCP port, reopen after 5 s); "
                        "times in emulator seconds from start (--speed scales them)")
    p.add_argument("--fault-seed", type=int, default=0,
                   help="seed for the random faults (same seed, same faults; default 0)")
    p.add_argument("--link", default=None, metavar="PATH",
                   help="with --pty: keep a symlink PATH pointing at the pty (a disconnect "
                        "fault reopens it there; default: a temp path when disconnect is used)")
    p.add_argument("--duration", type=float, default=None,
                   help="exit after this many real seconds (default: until Ctrl-C)")
    p.set_defaults(func=run)


def _emulated() -> list[str]:
    from tracker.controllers import names, with_emulator

    return names(with_emulator())


# Beyond these a simulated motor jumps in one tick or the run outlives any use of it.
MAX_SPEED = 10_000.0
MAX_DURATION_S = 365 * 86400.0


def _check_args(args: argparse.Namespace) -> None:
    import math

    from tracker.errors import ConfigError

    if not (math.isfinite(args.speed) and 0 < args.speed <= MAX_SPEED):
        raise ConfigError(f"--speed {args.speed:g} is invalid; use a number above 0 and at "
                          f"most {MAX_SPEED:g}")
    if args.duration is not None and not (math.isfinite(args.duration)
                                          and 0 < args.duration <= MAX_DURATION_S):
        raise ConfigError(f"--duration {args.duration:g} is invalid; use a number of seconds "
                          f"above 0 and at most {MAX_DURATION_S:g} (a year; leave it out to "
                          f"run until Ctrl-C)")
    if args.tcp is not None and not 0 <= args.tcp <= 65535:
        raise ConfigError(f"--tcp {args.tcp} is invalid; use a TCP port 1..65535 (0 = any "
                          f"free port)")


def _serve(ctrl, args: argparse.Namespace, needs_reopen: bool):
    """Serve ``ctrl`` on the TCP port or the pty the arguments ask for."""
    from tracker.commands._common import flag_first
    from tracker.emulator import serve_pty, serve_tcp
    from tracker.errors import ConfigError

    if args.tcp is not None:
        try:
            return serve_tcp(ctrl, args.tcp, args.bind)
        except OSError as e:
            raise ConfigError(f"cannot listen on {args.bind}:{args.tcp}: {e}; choose another "
                              f"--tcp port") from e
    link = args.link
    if link is None and needs_reopen:
        import os
        import tempfile
        link = os.path.join(tempfile.mkdtemp(prefix="tracker-emu-"), "ttyEMU0")
    try:
        return serve_pty(ctrl, link=link)
    except ConfigError as e:
        raise flag_first(e, "link", "--link") from None


def _controller_options(args: argparse.Namespace, entry):
    """The emulator's switches (GS-232 ``--strict-acks`` ..., SAK-232 ``--gs23``), or None."""
    from tracker.emulator import EmulatorOptions
    from tracker.errors import ConfigError

    if args.gs23:
        if entry.name != "sak232":
            raise ConfigError(f"--gs23 is a SAK-232 option; --protocol {entry.name} does not "
                              "take it")
        from tracker.emulator.sak232_controller import Sak232Options

        return Sak232Options(gs23=True)
    if entry.gs232_switches:
        return EmulatorOptions(
            strict_acks=args.strict_acks, one_space=args.one_space,
            readback_360=args.readback_360, end_behaviour=args.end, autobaud=args.autobaud)
    return None


def run(args: argparse.Namespace) -> int:
    import time

    from tracker.clock import SimClock, SystemClock
    from tracker.controllers import controller
    from tracker.emulator.factory import check_start_position, make_emulator
    from tracker.emulator.faults import FaultPlan, install
    from tracker.errors import ConfigError
    from tracker.mount import preset

    _check_args(args)
    entry = controller(args.protocol)
    if entry.emulator is None or entry.default_rotator is None:
        raise ConfigError(f"protocol {entry.name} has no emulator; emulated: "
                          f"{', '.join(_emulated())}")
    plan = FaultPlan.parse(args.fault, args.fault_seed)
    spec = preset(args.rotator or entry.default_rotator, args.mains)
    clock = SimClock(SystemClock().now(), speed=args.speed)
    kw: dict = {"az_deg": args.az}
    if entry.has_elevation:
        check_start_position(spec, args.az, args.el, az_name="--az", el_name="--el")
        kw["el_deg"] = args.el
    options = _controller_options(args, entry)
    if options is not None:
        kw["options"] = options
    ctrl = make_emulator(args.protocol, clock, spec, **kw)
    injector = install(ctrl, plan) if plan.specs else None
    server = _serve(ctrl, args, plan.needs_reopen)
    # handlers first: whoever reads the port line may signal at once
    stop = threading.Event()
    restore = _stop_on_signals(stop)
    tty = sys.stdout.isatty()
    started = time.monotonic()
    last = ""
    try:
        print(server.url, flush=True)
        while not stop.is_set():
            line = ctrl.status_line()
            if tty:
                print("\r" + line.ljust(100), end="", flush=True)
            elif line != last:
                print(line, flush=True)
            last = line
            wait_s = 0.2 if tty else 1.0
            if args.duration is not None:
                left_s = args.duration - (time.monotonic() - started)
                if left_s <= 0:
                    break
                wait_s = min(wait_s, left_s)
            stop.wait(wait_s)
    except KeyboardInterrupt:
        pass
    finally:
        restore()
        server.close()
        if tty:
            print()
        if injector is not None:
            print(injector.summary(), flush=True)
    return 0


def _stop_on_signals(stop: threading.Event) -> Callable[[], None]:
    """SIGTERM and SIGHUP end the run like Ctrl-C (port closed, fault summary printed).

    Needed because a process started in the background of a non-interactive shell inherits
    SIGINT as ignored, so a supervisor or a test can only stop it cleanly with these; under
    ``nohup`` SIGHUP stays ignored."""
    from tracker.session import STOP_SIGNALS, route_stop_signals

    wanted = tuple(sig for sig in STOP_SIGNALS if sig != signal.SIGINT)
    return route_stop_signals(lambda _signum, _frame: stop.set(), wanted)
