"""``tracker plan TARGET``: how the rotator will follow a pass, and why.

Prints the chosen mode and the reason, every candidate's figures side by side, the
pre-position move and time, the predicted max/mean pointing error, lost seconds, travel and
motor starts. ``--plot FILE.png|svg`` draws the sky plot (extra ``plot``).

More outputs of the same plan (such as ``--steptable FILE``) register in
:data:`OUTPUTS`: ``(flag, metavar, help, writer(plan, station, value, args))``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from datetime import timedelta

from tracker.commands._common import (
    add_rotator_args,
    add_station_args,
    add_target_args,
    add_time_args,
    clock_from_args,
    rotator_from_args,
    station_from_args,
    target_from_args,
    warn_element_age,
)


def _write_plot(plan, station, value: str, args: argparse.Namespace) -> None:
    from tracker.plot import sky_plot

    path = sky_plot(plan, station, value, force=args.force, label="--plot")
    print(f"sky plot written to {path}", file=sys.stderr)


OUTPUTS: list[tuple[str, str, str, Callable]] = [
    ("--plot", "FILE", "write a polar sky plot (.png or .svg; needs the 'plot' extra)",
     _write_plot),
]


def register(sub) -> None:
    p = sub.add_parser("plan", help="plan the rotator path for a pass (mode, errors, why)",
                       description="Plan how the rotator follows one pass: normal, 450 deg "
                                   "overlap, flip, keyhole sweep, unwind or ahead, with "
                                   "predicted pointing error after rate-limited motion.")
    p.add_argument("target", metavar="TARGET", help='satellite name or NORAD id, or Sun/Moon')
    p.add_argument("--pass", dest="pass_no", type=int, default=1, metavar="N",
                   help="which upcoming pass (1 = next, default; a pass in progress counts)")
    p.add_argument("--hours", type=float, default=48.0, metavar="H",
                   help="how far ahead to look for the pass (default 48)")
    add_rotator_args(p)
    p.add_argument("--current", nargs=2, type=float, metavar=("AZ", "EL"),
                   help="antenna's current mechanical az/el (default: the park position)")
    p.add_argument("--threshold", type=float, default=5.0, metavar="DEG",
                   help="error above which a second counts as lost (half beamwidth; default 5)")
    p.add_argument("--format", choices=("table", "json"), default="table")
    for flag, metavar, help_text, _ in OUTPUTS:
        p.add_argument(flag, metavar=metavar, help=help_text)
    p.add_argument("--force", action="store_true",
                   help="replace existing output files (otherwise they are never touched)")
    add_station_args(p)
    add_target_args(p)
    add_time_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tracker.errors import ConfigError, TargetError
    from tracker.passes import find_passes
    from tracker.planner import plan_pass

    if args.pass_no < 1:
        raise ConfigError(f"--pass {args.pass_no}: passes are numbered from 1 (the next)")
    if not 0 < args.hours <= 24 * 30:
        raise ConfigError("--hours must be more than 0 and at most 720")
    if not 0 < args.threshold <= 90:
        raise ConfigError("--threshold must be more than 0 and at most 90 degrees")
    _check_outputs(args)
    clock = clock_from_args(args, manual=True)
    now = clock.now()
    station = station_from_args(args, quiet=args.format != "table")
    spec = rotator_from_args(args)
    target = target_from_args(args.target, args)
    warn_element_age([target], now)
    passes = find_passes(target, station, now, now + timedelta(hours=args.hours))
    if len(passes) < args.pass_no:
        raise TargetError(f"{target.name}: only {len(passes)} pass(es) in the next "
                          f"{args.hours:g} h; use a smaller --pass or a larger --hours")
    p = passes[args.pass_no - 1]
    if p.always_up:
        raise TargetError(f"{target.name} is above the horizon the whole time (no pass to "
                          f"plan); point at it with `tracker track`")
    track = p.track(step_s=1.0, pad_s=60.0)
    current = tuple(args.current) if args.current else None
    plan = plan_pass(track, spec, station, current, threshold_deg=args.threshold)
    if args.format == "json":
        out = plan.summary()
        out["station"] = station.name
        out["preposition_moves"] = [m.__dict__ for m in plan.preposition_moves]
        out["park_moves"] = [m.__dict__ for m in plan.park_moves]
        json.dump(out, sys.stdout, indent=2, default=float)
        print()
    else:
        print(format_plan(plan, station.name))
    for flag, _, _, writer in OUTPUTS:
        value = getattr(args, flag.lstrip("-").replace("-", "_"), None)
        if value:
            writer(plan, station, value, args)
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse an unusable output path before planning (and before printing the plan)."""
    from tracker.files import check_output
    from tracker.plot import check_plot_path

    if args.plot:
        check_plot_path(args.plot, force=args.force, label="--plot")
    if args.steptable:
        check_output(args.steptable, force=args.force, label="--steptable")


def _utc(t_s: float) -> str:
    from tracker.timescale import utc_strftime

    return utc_strftime(t_s, "%Y-%m-%d %H:%M:%S")


def format_plan(plan, station_name: str) -> str:
    """The human-readable report: mode and reason, candidates side by side, moves, figures."""
    vis_t = plan.t_s[plan.visible]
    spec = plan.spec
    lines = [
        f"{plan.track.name} over {station_name} on {spec.name} "
        f"(az span {spec.az_span_deg:g}, stop {spec.stop_bearing_deg:g}, "
        + (f"el {spec.el_min_deg:g}-{spec.el_max_deg:g})" if spec.has_elevation
           else "azimuth only)"),
        f"AOS {_utc(vis_t[0])} UTC   LOS {_utc(vis_t[-1])} UTC   "
        f"max el {float(plan.track.el_deg[plan.visible].max()):.1f} deg",
        "",
        f"mode: {plan.mode}",
        f"why:  {plan.reason}",
        "",
        f"{'candidate':<10} {'fits':>4} {'lost s':>7} {'max err':>8} {'mean err':>8} "
        f"{'p99 err':>8} {'travel':>7} {'starts':>6}  note",
    ]
    for i, c in enumerate(plan.candidates):
        mark = "*" if i == 0 else " "
        lines.append(f"{mark}{c.mode:<9} {'yes' if c.fits else 'no':>4} "
                     f"{c.lost_track_s:7.0f} {c.max_error_deg:8.2f} {c.mean_error_deg:8.2f} "
                     f"{c.p99_error_deg:8.2f} {c.travel_deg:7.0f} {c.motor_starts:6d}  "
                     f"{c.note}")
    lines.append("")

    def el_text(el_deg: float, width: int = 0) -> str:  # az-only rotators have no el axis
        return f"  el {el_deg:{width}.1f}" if spec.has_elevation else ""

    pa, pe = plan.preposition
    lines.append(f"pre-position: start {_utc(plan.preposition_t_s)} UTC to mech az {pa:g} "
                 f"(bearing {float(spec.bearing_of(pa)):g})"
                 + (f", el {pe:g}" if spec.has_elevation else "")
                 + ("" if plan.preposition_moves else " (already there)"))
    for m in plan.preposition_moves:
        lines.append(f"  {_utc(m.t_s)}  az {m.az_deg:6.1f}{el_text(m.el_deg, 5)}")
    if plan.park_moves:
        lines.append(f"park after LOS: from {_utc(plan.park_moves[0].t_s)} UTC")
        for m in plan.park_moves:
            lines.append(f"  {_utc(m.t_s)}  az {m.az_deg:6.1f}{el_text(m.el_deg, 5)}")
    lines.append("")
    lines.append(f"predicted pointing error: max {plan.max_error_deg:.2f} deg, mean "
                 f"{plan.mean_error_deg:.2f} deg, p99 {plan.p99_error_deg:.2f} deg; lost "
                 f"{plan.lost_track_s:.0f} s (error > {plan.threshold_deg:g} deg); travel "
                 f"{plan.travel_deg:.0f} deg; motor starts {plan.motor_starts}")
    # The plan commands every resolution step; the live loop holds within its deadband and
    # starts the motors far less often, so say which count this is.
    lines.append(f"(motor starts count every {spec.resolution_deg:g} deg command step of "
                 f"this path, as a step table would send them; live tracking holds within "
                 f"its deadband and starts the motors less often)")
    return "\n".join(lines)


def _write_steptable(plan, station, value: str, args: argparse.Namespace) -> None:
    from tracker.commands.upload import write_steptable_for_plan

    write_steptable_for_plan(plan, station, value, args)


OUTPUTS.append(("--steptable", "FILE", "write the pass as a GS-232B step-table plan file "
                "(send it later with `tracker upload --from FILE`)", _write_steptable))
