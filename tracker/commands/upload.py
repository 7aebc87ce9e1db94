"""``tracker upload TARGET``: compile a pass into a GS-232 step table, upload it, send T on time.

Without ``--port`` the built-in GS-232B emulator runs in-process on a simulated clock (a
demonstration: nothing real moves). ``--dry-run`` only prints the exact lines; ``--from FILE``
sends a plan file written by ``tracker plan --steptable FILE``.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import TYPE_CHECKING, NamedTuple

from tracker.commands._common import (
    add_rotator_args,
    add_station_args,
    add_target_args,
    add_time_args,
    check_baud_arg,
    check_number_arg,
    clock_from_args,
    rotator_from_args,
    speed_arg,
    station_from_args,
    target_from_args,
)

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.mount import RotatorSpec
    from tracker.protocols.base import Capabilities
    from tracker.skytrack import SkyTrack
    from tracker.steptable import StepProgram

DEMO_SPEED = 20.0


def register(sub) -> None:
    p = sub.add_parser(
        "upload", help="upload a pass as a timed step table (W/M + T) to the controller",
        description="Compile the next pass of TARGET into a GS-232 long-form step table, "
                    "pre-position before AOS, send T on time and watch the controller step "
                    "through it (N, C2). Without --port: a simulation on the built-in "
                    "emulator.")
    p.add_argument("target", metavar="TARGET", nargs="?",
                   help="satellite name or NORAD id, or e.g. Moon (not needed with --from)")
    p.add_argument("--pass", dest="pass_no", type=int, default=1, metavar="N",
                   help="which upcoming pass: 1 = the next one (default)")
    p.add_argument("--days", type=float, default=2.0, metavar="D",
                   help="search window for passes (default 2 days)")
    add_rotator_args(p)
    p.add_argument("--port", metavar="URL",
                   help="serial device or pyserial URL; omitted: simulate on the built-in "
                        "emulator")
    p.add_argument("--protocol", default=None,
                   help="controller profile: gs232a, gs232b or k3ng (default gs232b, or the "
                        "plan file's)")
    p.add_argument("--baud", type=int, default=9600, help="baud rate (default 9600)")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--interval", type=int, metavar="S",
                     help="step interval sss in whole seconds, 1-999 (K3NG steps every S+1)")
    how.add_argument("--max-error", type=float, metavar="DEG", dest="max_error",
                     help="largest interval whose predicted pointing error stays within DEG")
    p.add_argument("--detach", action="store_true",
                   help="exit right after T; the controller steps by itself")
    p.add_argument("--dry-run", action="store_true",
                   help="print the plan header and the exact command lines; send nothing")
    p.add_argument("--from", dest="from_file", metavar="FILE",
                   help="send a plan file from `tracker plan --steptable FILE`")
    p.add_argument("--now", action="store_true",
                   help="with --from: the T time has passed; resume from the current point")
    p.add_argument("--speed", type=speed_arg, default=DEMO_SPEED,
                   help=f"simulation speed without --port (default {DEMO_SPEED:g}x); 'max': "
                        f"virtual time, no waiting (the emulator runs in-process)")
    add_station_args(p)
    add_target_args(p)
    add_time_args(p)
    p.set_defaults(func=run_worded_for_cli)


class CompiledPass(NamedTuple):
    """What :func:`build_program` made: the program, its plan-file header, the sky track it
    was compiled from (to measure the pointing error against) and the demo's note ("" unless
    a simulation moved to the epoch of stale elements)."""

    program: StepProgram
    header: dict
    sky: SkyTrack
    note: str = ""


def build_program(args: argparse.Namespace, now_s: float, current=None,
                  capabilities: Capabilities | None = None, demo: bool = False
                  ) -> CompiledPass:
    """Find the pass and compile it. With ``capabilities`` (what the connected controller
    accepts) the pass is planned inside them: a controller in its 360 deg mode gets no
    overlap plan, one taking elevation up to 90 no flip. A ``demo`` (the simulation) without
    ``--at`` replays a pass near the epoch of stale elements, as ``tracker track`` does."""
    from datetime import datetime, timedelta, timezone

    from tracker.commands._common import warn_element_age
    from tracker.errors import ConfigError, LimitError
    from tracker.passes import find_passes
    from tracker.steptable import compile_pass
    from tracker.tracking import demo_start

    if not args.target:
        raise ConfigError("give a TARGET (e.g. 'ISS') or --from FILE")
    if not (0 < args.days <= 30):
        raise ConfigError(f"--days must be more than 0 and at most 30; got {args.days:g}")
    if args.pass_no < 1:
        raise ConfigError(f"--pass must be 1 or more (1 = the next pass); got {args.pass_no}")
    spec = rotator_from_args(args)
    station = station_from_args(args, quiet=True)
    if capabilities is not None:
        spec = _inside_the_controller(spec, station, capabilities)
    target = target_from_args(args.target, args)
    now, note = datetime.fromtimestamp(now_s, timezone.utc), ""
    if demo and args.at is None:
        now, note = demo_start(target, now)
        now_s = now.timestamp()
    warn_element_age([target], now)  # a demo moved to a stale epoch says so in its note
    passes = find_passes(target, station, now, now + timedelta(days=args.days))
    passes = [p for p in passes if p.los.timestamp() > now_s + 10.0]
    if len(passes) < args.pass_no:
        raise ConfigError(f"{target.name}: only {len(passes)} pass(es) in the next "
                          f"{args.days:g} days; choose --pass 1..{len(passes)} or a longer "
                          f"--days")
    ps = passes[args.pass_no - 1]
    track = ps.track(1.0, pad_s=60.0)
    sat = getattr(target, "satellite", None)
    epoch = sat.epoch.utc_iso() if sat is not None and hasattr(sat, "epoch") else "n/a"
    header = {"station": f"{station.name} lat {station.lat_deg:g} lon {station.lon_deg:g} "
                         f"alt {station.alt_m:g} m",
              "target": target.name, "element_epoch": epoch,
              "aos_utc": ps.aos.isoformat(), "max_el_deg": f"{ps.max_el_deg:.1f}"}
    try:
        program = compile_pass(track, spec, station, args.protocol, current=current,
                               interval_s=args.interval, max_error_deg=args.max_error,
                               baud=args.baud, meta=header)
    except LimitError as e:
        if not e.problem:
            raise
        raise LimitError(f"{e.problem}. Raise --max-error or give --interval") from None
    _warn_large_error(program, track)
    return CompiledPass(program, header, track, note)


def _warn_large_error(program, track) -> None:
    """A predicted error beyond a beamwidth gets one line saying why (on stderr: a dry run's
    stdout is the plan file)."""
    from tracker.planner import error_cause

    p = program.prediction
    cause = error_cause(track, program.spec, str(program.meta.get("mode", "")), p.t_s,
                        p.error_deg, step_s=program.period_s)
    if cause:
        advice = ("; a shorter --interval (or --max-error DEG) steps closer"
                  if "interval" in cause else "")
        print(f"tracker: warning: {cause}{advice}", file=sys.stderr)


def _inside_the_controller(spec: RotatorSpec, station, capabilities: Capabilities
                           ) -> RotatorSpec:
    """The spec narrowed to the controller's effective limits (said when it narrows)."""
    from tracker.session import EffectiveLimits

    limits = EffectiveLimits.of(spec, station, capabilities)
    narrowed = limits.rotator()
    if narrowed != spec:
        print(f"planning inside the controller's limits: {limits.describe()}", flush=True)
    return narrowed


def run_worded_for_cli(args: argparse.Namespace) -> int:
    """:func:`run`, its errors about plan files advising the command that makes one."""
    from tracker.commands._common import in_flag_terms
    from tracker.errors import TrackerError
    from tracker.steptable import MAKE_PLAN

    try:
        return run(args)
    except TrackerError as e:
        in_flag_terms(e, [(MAKE_PLAN, "`tracker plan ... --steptable FILE`")])
        raise


def run(args: argparse.Namespace) -> int:
    from tracker.errors import ConfigError
    from tracker.steptable import (
        check_tables_fit,
        format_plan_file,
        read_plan_file,
        read_plan_text,
        table_profile,
    )
    from tracker.transport import is_emulated
    from tracker.upload import resume_schedule

    check_baud_arg(args)
    check_number_arg(args, "max_error", 0.1, 180.0, "degrees")
    if args.from_file and not args.protocol:
        args.protocol = read_plan_file(args.from_file).header.get("profile") or "gs232b"
    args.protocol = args.protocol or "gs232b"
    table_profile(args.protocol)  # refuse a protocol without tables up front
    if args.now and not args.from_file:
        raise ConfigError("--now only applies to --from FILE")
    clock = clock_from_args(args)
    if args.port and is_emulated(args.port):
        from tracker.emulator.virtual import clock_of

        # an emu:// bench made by the caller brings its own (virtual) clock
        clock = clock_of(args.port) or clock
    simulate = not args.port and not args.dry_run
    if args.from_file:
        plan = read_plan_file(args.from_file)
        tables = list(plan.tables)
        if plan.header.get("profile") and \
                plan.header["profile"] != table_profile(args.protocol).name:
            raise ConfigError(f"{args.from_file} was written for {plan.header['profile']}, "
                              f"not {args.protocol}")
        if args.dry_run:
            sys.stdout.write(read_plan_text(args.from_file))
            return 0
        now = clock.timestamp() if not simulate else tables[0].upload_t_s - 1.0
        if args.port and tables[0].start_t_s < now:
            if not args.now:
                late = now - tables[0].start_t_s
                raise ConfigError(f"{args.from_file}: its T time passed {late:.0f} s ago; "
                                  f"make a new plan, or add --now to resume from the point "
                                  f"due now")
            tables = resume_schedule(tables, now, args.baud)
        spec = _plan_file_rotator(args, plan.header)
        check_tables_fit(tables, spec, station_from_args(args, quiet=True), str(args.from_file))
        return _send(args, tables, clock, simulate, spec)

    now_s = clock.timestamp()
    if not args.port or args.dry_run:
        # a dry run, or a simulation on an emulator made from the rotator spec itself
        built = build_program(args, now_s, demo=simulate)
        program = built.program
        if args.dry_run:
            sys.stdout.write(format_plan_file(program, built.header))
            return 0
        print(program.summary())
        return _send(args, list(program.tables), clock, simulate, program.spec,
                     sky=built.sky, note=built.note)
    # A real controller: connect first, so the pass is planned inside what it accepts.
    from tracker.session import ControllerSession

    driver = _open_driver(args, args.port, rotator_from_args(args))
    try:
        # The port is open: a signal or an error while planning ends with all-stop too.
        with ControllerSession(driver.stop, stop_at_end=False):
            built = build_program(args, now_s, capabilities=driver.capabilities)
            print(built.program.summary())
            tables = resume_schedule(list(built.program.tables), clock.timestamp(),
                                     args.baud)
    except BaseException:
        driver.close()
        raise
    return _send(args, tables, clock, simulate, built.program.spec, driver, sky=built.sky)


def _plan_file_rotator(args: argparse.Namespace, header: dict) -> RotatorSpec:
    """The rotator a plan file was compiled for (``G-5500@50Hz``, a config section ...);
    ``--rotator`` overrides it."""
    from tracker.errors import ConfigError

    if args.rotator or not header.get("rotator"):
        return rotator_from_args(args)
    name, _, suffix = header["rotator"].partition("@")
    if suffix == "50Hz" and args.mains_hz is None:
        args.mains_hz = 50
    try:
        return rotator_from_args(args, name)
    except ConfigError:
        raise ConfigError(f"{args.from_file} was compiled for rotator {header['rotator']!r}, "
                          f"which is neither a preset nor a [rotator.{name}] section of the "
                          f"config file; name the rotator with --rotator") from None


def _open_driver(args: argparse.Namespace, url: str, spec: RotatorSpec, **timing):
    """The driver for ``url`` at the rotator's scale; the runner decides about all-stop."""
    from tracker.protocols import open_driver
    from tracker.session import driver_limits

    driver = open_driver(url, args.protocol, baudrate=args.baud, **driver_limits(spec),
                         **timing)
    driver.stop_on_exit = False  # the runner decides: all-stop on every path but --detach
    return driver


def _send(args, tables, clock, simulate: bool, spec: RotatorSpec, driver=None, *,
          sky: SkyTrack | None = None, note: str = "") -> int:
    """Run ``tables`` on ``driver`` (opened here for ``--from`` and the simulation); with
    ``sky`` (the target's track) the pointing error is measured. ``note``: the simulation's
    note on replayed stale elements."""
    from datetime import datetime, timezone

    from tracker.clock import SimClock
    from tracker.errors import ConfigError
    from tracker.session import ControllerSession
    from tracker.upload import TableRunner

    server = None
    if simulate:
        from tracker.emulator import Gs232Controller

        virtual = args.speed == math.inf
        if not virtual and not (math.isfinite(args.speed) and 0 < args.speed <= 10_000):
            raise ConfigError(f"--speed {args.speed:g} is invalid; use a number above 0 and "
                              f"at most 10000, or max")
        start = datetime.fromtimestamp(tables[0].upload_t_s - 1.0, timezone.utc)
        if virtual:
            from tracker.clock import LockstepClock
            from tracker.emulator.virtual import Bench

            # Virtual time: the emulator in-process on the runner's clock, every wait a jump.
            clock = LockstepClock(start)
            server = Bench(Gs232Controller(args.protocol, spec, clock=clock))
            where, pace = "in-process", "virtual time (no waiting)"
        else:
            from tracker.emulator import serve_pty

            clock = SimClock(start, speed=args.speed)
            server = serve_pty(Gs232Controller(args.protocol, spec, clock=clock))
            where, pace = f"on {server.url}", f"a simulated clock at {args.speed:g}x"
        print(f"SIMULATION: no --port given, so this runs against the built-in "
              f"{args.protocol} emulator {where} with {pace}, starting just before the "
              f"upload time. Nothing real moves.", flush=True)
        if note:
            print(note, flush=True)
        url = server.url
        # Read deadlines and pacing run on the port's time (real, on a pty), whatever
        # the simulated clock's speed.
        timing = dict(clock=clock)
    else:
        url = args.port
        timing = {}
    try:
        driver = driver or _open_driver(args, url, spec, **timing)
    except BaseException:
        if server is not None:
            server.close()
        raise
    log = lambda m: print(f"{_utc(clock)}  {m}", flush=True)  # noqa: E731
    try:
        # The runner stops at the end (not after --detach) and on its own errors; the
        # session makes SIGTERM / SIGHUP take the Ctrl-C path and has the last word, S.
        with ControllerSession(driver.stop, stop_at_end=False,
                               on_stop_failed=lambda why: log(f"all-stop failed: {why}")):
            runner = TableRunner(driver, clock, baud=args.baud, spec=spec, log=log, sky=sky)
            try:
                report = runner.run(tables, detach=args.detach)
            except ConfigError as e:
                if not (args.detach and e.problem):
                    raise
                # the problem starts with the parameter's name, which is the flag's
                raise ConfigError(f"--{e.problem}; use a longer --interval or stay "
                                  f"attached") from None
    finally:
        driver.close()
        if server is not None:
            server.close()
    for u in report.uploads:
        print(f"upload {u['what']}: {u['bytes']} bytes, {u['upload_s']:.2f} s "
              f"(wire time at {args.baud} baud: {u['wire_s']:.2f} s)")
    late = ", ".join(f"{x * 1000:+.0f} ms" for x in report.t_late_s)
    print(f"T timing: {late}; resyncs: {len(report.resyncs)}"
          + ("; detached, the controller steps on by itself" if report.detached else ""))
    if not report.detached:
        print(_measured(report, runner.error_label, sky is not None))
    return 0


def _measured(report, label: str, has_sky: bool) -> str:
    """The pass's measured max error, or why it is unknown."""
    if report.max_error_deg is not None:
        return (f"measured: max {label} {report.max_error_deg:.1f} deg over "
                f"{len(report.errors_deg)} read-backs")
    why = ("the plan file carries no sky track of the target" if not has_sky
           else "no read-back during the pass")
    return f"measured {label}: unknown ({why})"


def _utc(clock) -> str:
    return clock.now().strftime("%H:%M:%S")


def write_steptable_for_plan(plan, station, path: str, args: argparse.Namespace) -> None:
    """``tracker plan ... --steptable FILE``: the pass as a GS-232B step-table plan file.

    Uses the gs232b profile and the smallest interval that fits one table; for another
    protocol or interval use ``tracker upload ... --dry-run [--protocol P] [--interval S]``,
    which prints the same file format.
    """
    from tracker.steptable import compile_pass, write_plan_file

    header = {"station": f"{station.name} lat {station.lat_deg:g} lon {station.lon_deg:g} "
                         f"alt {station.alt_m:g} m",
              "target": plan.track.name or getattr(args, "target", "")}
    try:
        sat = getattr(target_from_args(args.target, args), "satellite", None)
        header["element_epoch"] = sat.epoch.utc_iso() if sat is not None else "n/a"
    except Exception:  # the epoch is informative only; never fail the plan for it
        header["element_epoch"] = "n/a"
    current = tuple(args.current) if getattr(args, "current", None) else None
    program = compile_pass(plan.track, plan.spec, station, "gs232b", current=current,
                           meta=header)
    write_plan_file(program, path, force=getattr(args, "force", False), label="--steptable")
    print(f"step table written to {path}: {program.summary()}", file=sys.stderr)
