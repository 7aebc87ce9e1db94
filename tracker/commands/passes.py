"""``tracker passes``: list the passes of satellites (or the Sun, Moon, ...) over the station.

Output formats (``--format``):

* ``table`` (default): rich table on a terminal, aligned plain text otherwise — AOS in local
  time and UTC, duration, max elevation, AOS/LOS azimuth with compass point, sunlit/visible.
* ``csv`` and ``json``: the pass record shared with ``tracker batch`` and ``tracker schedule``
  (:data:`tracker.export.PASS_FIELDS`, docs/pass-schema.md).
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timedelta

from tracker.commands._common import (
    add_station_args,
    add_target_args,
    add_time_args,
    catalog_from_args,
    clock_from_args,
    station_from_args,
    target_from_args,
    warn_element_age,
)
from tracker.event_labels import event_labels


def register(sub) -> None:
    p = sub.add_parser("passes", help="list upcoming passes over the station",
                       description="List the passes of one or more targets (satellite names, "
                                   "NORAD ids, or e.g. Sun/Moon) or a whole --group.")
    p.add_argument("targets", nargs="*", metavar="TARGET",
                   help='satellite name or NORAD id, e.g. "ISS (ZARYA)" or 25544')
    window = p.add_mutually_exclusive_group()
    window.add_argument("--hours", type=float, metavar="H", help="window length in hours")
    window.add_argument("--days", type=float, metavar="D",
                        help="window length in days (default 1)")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table",
                   help="output format (default: table)")
    add_station_args(p)
    add_target_args(p)
    add_time_args(p)
    p.set_defaults(func=run)


def window_s(args: argparse.Namespace) -> float:
    from tracker.errors import ConfigError

    if args.hours is not None:
        seconds = args.hours * 3600.0
    elif args.days is not None:
        seconds = args.days * 86400.0
    else:
        seconds = 86400.0
    if not (0 < seconds <= 60 * 86400.0):
        raise ConfigError(f"the window must be more than 0 and at most 60 days; got "
                          f"{seconds / 3600.0:g} hours")
    return seconds


def targets_from_args(args: argparse.Namespace, now: datetime) -> list:
    """Named targets, or every satellite of --group."""
    from tracker.errors import ConfigError
    from tracker.targets import SatelliteTarget

    if args.targets:
        targets = [target_from_args(name, args) for name in args.targets]
    elif getattr(args, "group", None):
        targets = [SatelliteTarget(es) for es in catalog_from_args(args)]
    else:
        raise ConfigError('name a target, e.g. tracker passes "ISS (ZARYA)", or a group, '
                          "e.g. tracker passes --group amateur")
    return targets


def collect_passes(targets, station, start: datetime, end: datetime) -> list:
    """Passes of every target, sorted by AOS. With several targets a satellite whose elements
    fail to propagate is skipped with a note (it must not hide the others)."""
    from tracker.errors import PropagationError
    from tracker.passes import find_passes

    out = []
    for target in targets:
        try:
            out.extend(find_passes(target, station, start, end))
        except PropagationError as e:
            if len(targets) == 1:
                raise
            print(f"tracker: skipped: {e}", file=sys.stderr)
    out.sort(key=lambda p: (p.aos, p.target_name))
    return out


def run(args: argparse.Namespace) -> int:
    clock = clock_from_args(args, manual=True)
    now = clock.now()
    targets = targets_from_args(args, now)
    # Age warnings only once station and window are valid: an error is then the one line.
    end = now + timedelta(seconds=window_s(args))
    station = station_from_args(args, quiet=args.format != "table")
    warn_element_age(targets, now)
    passes = collect_passes(targets, station, now, end)
    if args.format in ("csv", "json"):
        from tracker.export import pass_records, render, station_meta
        from tracker.timescale import iso_utc

        meta = {"start": iso_utc(now), "end": iso_utc(end), "stations": [station_meta(station)],
                "targets": [t.name for t in targets]}
        sys.stdout.write(render(args.format, pass_records(passes), meta=meta))
    else:
        write_table(passes, station, targets, now, end, sys.stdout)
    return 0


def format_duration(seconds: float) -> str:
    """Compact duration: 45s, 4m12s, 1h23m, 2d03h."""
    s = round(max(seconds, 0.0))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    if s < 86400:
        return f"{s // 3600}h{(s % 3600) // 60:02d}m"
    return f"{s // 86400}d{(s % 86400) // 3600:02d}h"


def _az(az_deg: float) -> str:
    from tracker.skytrack import compass_point

    return f"{az_deg:3.0f} {compass_point(az_deg):<3}"


def table_rows(passes, show_target: bool) -> tuple[list[str], list[list[str]]]:
    """Header and cells; a separate UTC column only when local time is not UTC."""
    zone = passes[0].aos.astimezone().strftime("%Z") if passes else ""
    local_is_utc = bool(passes) and passes[0].aos.astimezone().utcoffset().total_seconds() == 0
    kinds = {p.kind for p in passes}
    if len(kinds) == 1:
        start, _, end = (label[:1].upper() + label[1:] for label in event_labels(kinds.pop()))
    else:
        start, end = "AOS/Rise", "LOS/Set"
    header = [f"{start} ({zone or 'local'})", f"{start} UTC", "Duration", "Max El",
              f"{start} Az", f"{end} Az", "Vis"]
    if local_is_utc:
        header.pop(1)
    if show_target:
        header.insert(0, "Target")
    rows = []
    for p in passes:
        aos_local = p.aos.astimezone().strftime("%a %m-%d %H:%M:%S")  # year in the title
        aos_utc = p.aos.strftime("%H:%M:%S")
        if p.always_up:
            aos_local, aos_utc = "always up", "-"
        elif not p.aos_known:
            aos_local += " (up at start)"
        elif p.in_progress_at_start:
            aos_local += " *"
        dur = format_duration(p.duration_s) + ("" if p.los_known else "+")
        vis = "visible" if p.visible else ("sunlit" if p.sunlit else "")
        row = [aos_local, aos_utc, dur, f"{p.max_el_deg:5.1f}°", _az(p.aos_az_deg),
               _az(p.los_az_deg), vis]
        if local_is_utc:
            row.pop(1)
        if show_target:
            row.insert(0, p.target_name)
        rows.append(row)
    return header, rows


def write_table(passes, station, targets, start: datetime, end: datetime, out) -> None:
    names = ", ".join(t.name for t in targets[:3]) + (
        f" and {len(targets) - 3} more" if len(targets) > 3 else "")
    where = (f"{station.name} ({station.lat_deg:.4f}, {station.lon_deg:.4f}), "
             f"min el {station.min_el_deg:g}°" + (" + horizon mask" if station.mask else ""))
    title = (f"Passes of {names} over {where}, "
             f"{start.strftime('%Y-%m-%d %H:%M')} .. {end.strftime('%Y-%m-%d %H:%M')} UTC")
    if not passes:
        print(f"{title}: no passes.", file=out)
        return
    header, rows = table_rows(passes, show_target=len(targets) > 1)
    if out.isatty():
        from rich import box
        from rich.console import Console
        from rich.table import Table

        table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD, pad_edge=False,
                      collapse_padding=True)
        for h in header:
            if h == "Target":
                table.add_column(h, min_width=12, overflow="fold")
            else:
                table.add_column(h, justify="right" if h in ("Duration", "Max El") else "left",
                                 no_wrap=True)
        for r in rows:
            table.add_row(*r)
        Console(file=out).print(table)
    else:
        print(title, file=out)
        widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
        print("  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)).rstrip(),
              file=out)
        for r in rows:
            print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip(),
                  file=out)
    # Only rows that carry the "*" (an always-up or up-at-start row says so itself).
    if any(p.in_progress_at_start and p.aos_known and not p.always_up for p in passes):
        print("* already in progress at the window start (real start time shown)", file=out)
