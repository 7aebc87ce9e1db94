"""``tracker next TARGET``: one line — the next AOS with a countdown, or "up now, LOS in ..".

Exit code 0 when a pass (or the target being up) was found, 1 when there is no pass in the
search window (``--days``, default 10), 2 for errors. "No pass" is a normal answer (a GEO
satellite never rising, a polar orbit from the wrong latitude), not bad input, so it keeps
grep's convention — 1 "nothing found", 2 "trouble" — and scripts can tell the two apart.
"""

from __future__ import annotations

import argparse
from datetime import timedelta

from tracker.commands._common import (
    add_station_args,
    add_target_args,
    add_time_args,
    clock_from_args,
    station_from_args,
    target_from_args,
)
from tracker.event_labels import event_labels


def register(sub) -> None:
    p = sub.add_parser("next", help="when is the next pass of a target (one line)",
                       description="Print one line: the next AOS of TARGET with a countdown, "
                                   "or 'up now, LOS in ...'. Exit status: 0 a pass was "
                                   "found, 1 no pass in the window (an answer, as grep "
                                   "finding nothing; the line says so), 2 an error.")
    p.add_argument("target", metavar="TARGET", help='satellite name or NORAD id, or e.g. Sun')
    p.add_argument("--days", type=float, default=10.0, metavar="D",
                   help="how far ahead to search (default 10 days)")
    add_station_args(p)
    add_target_args(p)
    add_time_args(p)
    p.set_defaults(func=run)


def next_line(target, station, now, days: float) -> tuple[str, bool]:
    """The one-line answer and whether a pass was found."""
    from tracker.commands.passes import format_duration
    from tracker.errors import ConfigError
    from tracker.passes import find_passes
    from tracker.skytrack import compass_point

    if not (0 < days <= 60):
        raise ConfigError(f"--days must be more than 0 and at most 60; got {days:g}")
    # Look one day ahead first (cheap, and enough for nearly every LEO satellite), then on.
    passes = find_passes(target, station, now, now + timedelta(days=min(days, 1.0)))
    if not passes and days > 1.0:
        passes = find_passes(target, station, now, now + timedelta(days=days))
    if not passes:
        return (f"{target.name}: no pass above {station.min_el_deg:g}° in the next "
                f"{days:g} days"), False
    p = passes[0]
    if p.always_up:
        return (f"{target.name}: always up (el {p.max_el_deg:.0f}° max, az "
                f"{p.tca_az_deg:.0f}° {compass_point(p.tca_az_deg)})"), True
    if p.aos <= now:
        track = target.observe(station, [now.timestamp()])
        el_now, az_now = float(track.el_deg[0]), float(track.az_deg[0])
        los = p.los.strftime("%H:%M:%S UTC")
        more = "+" if not p.los_known else ""
        return (f"{target.name}: up now at az {az_now:.0f}° {compass_point(az_now)}, el "
                f"{el_now:.0f}°, {event_labels(target.kind)[2]} in "
                f"{format_duration((p.los - now).total_seconds())}"
                f"{more} ({los}, az {p.los_az_deg:.0f}° {compass_point(p.los_az_deg)}), "
                f"max el {p.max_el_deg:.0f}°"), True
    rise, _, _ = event_labels(target.kind)
    return (f"{target.name}: next {rise} {p.aos.strftime('%Y-%m-%d %H:%M:%S UTC')} in "
            f"{format_duration((p.aos - now).total_seconds())}, max el {p.max_el_deg:.0f}°, "
            f"{rise} az {p.aos_az_deg:.0f}° {compass_point(p.aos_az_deg)}, duration "
            f"{format_duration(p.duration_s)}"), True


def run(args: argparse.Namespace) -> int:
    from tracker.commands._common import warn_element_age

    now = clock_from_args(args, manual=True).now()
    target = target_from_args(args.target, args)
    station = station_from_args(args)
    warn_element_age([target], now)
    line, found = next_line(target, station, now, args.days)
    print(line)
    return 0 if found else 1
