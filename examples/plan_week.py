"""Plan a week of amateur-satellite passes for one station: CSV + iCalendar (+ a schedule).

Runs on a fresh install with no network: it uses the TLE snapshot bundled with the package
(``tle/data/amateur.txt``, epochs around 2026-08-22), so the default week starts there.

    python examples/plan_week.py                       # Delft, week from 2026-08-22 13:45 UTC
    python examples/plan_week.py --lat 40 --lon -105.3 --name Boulder --out plans/
    python examples/plan_week.py --start 2026-08-24T00:00Z --min-max-el 20 --rotator G-5500

Writes ``passes.csv`` (every pass, with the planner's summary above --min-max-el),
``passes.ics`` (import into any calendar) and ``schedule.csv`` (which passes one rotator can
track when they overlap, every satellite at priority 1 unless --priority NAME=N).
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timedelta, timezone
from pathlib import Path

from tracker.api import (
    Catalog,
    ConfigError,
    Station,
    find_passes_batch,
    parse_priorities,
    pass_records,
    plan_summaries,
    preset,
    satrecs_of,
    schedule_passes,
    to_csv,
    to_ics,
    write_atomic,
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--name", default="Delft")
    ap.add_argument("--lat", type=float, default=52.0)
    ap.add_argument("--lon", type=float, default=4.37)
    ap.add_argument("--alt", type=float, default=10.0)
    ap.add_argument("--start", default="2026-08-22T13:45:00+00:00", help="ISO-8601 UTC")
    ap.add_argument("--days", type=float, default=7.0)
    ap.add_argument("--min-el", type=float, default=0.0)
    ap.add_argument("--min-max-el", type=float, default=15.0,
                    help="plan (and schedule) passes reaching this elevation")
    ap.add_argument("--rotator", default="G-5500")
    ap.add_argument("--priority", action="append", default=[], metavar="NAME=N")
    ap.add_argument("--out", default="plan-week", help="output folder")
    ap.add_argument("--force", action="store_true", help="replace the files of an earlier run")
    args = ap.parse_args(argv)

    start = datetime.fromisoformat(args.start.replace("Z", "+00:00")).astimezone(timezone.utc)
    end = start + timedelta(days=args.days)
    station = Station(args.name, args.lat, args.lon, args.alt, args.min_el)
    catalog = Catalog.bundled_snapshot().group("amateur")
    satrecs, names = satrecs_of(catalog)
    table = find_passes_batch(satrecs, names, [station], start, end)
    table = table.select(table.passes["max_el_deg"] >= args.min_max_el)
    spec = preset(args.rotator)
    records = pass_records(table, plan_summaries(table, satrecs, spec, args.min_max_el))

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "passes.csv", to_csv(records), force=args.force)
    write_atomic(out / "passes.ics", to_ics(records, start.timestamp(),
                                           f"Amateur passes over {station.name}"),
                 force=args.force)
    sched = schedule_passes(records, spec, parse_priorities(args.priority))
    write_atomic(out / "schedule.csv", to_csv(records.take(sched.chosen)), force=args.force)
    modes: dict[str, int] = {}
    for mode in records["plan_mode"].tolist():
        if mode:
            modes[mode] = modes.get(mode, 0) + 1
    print(f"{len(records)} passes of {len(names)} amateur satellites above "
          f"{args.min_max_el:g} deg over {station.name}, {start:%Y-%m-%d %H:%M} UTC + "
          f"{args.days:g} days")
    print(f"plan modes for {spec.name}: " + ", ".join(f"{k} {v}" for k, v in
                                                       sorted(modes.items())))
    print(f"one rotator can track {len(sched.chosen)} of them; wrote {out}/passes.csv, "
          f"{out}/passes.ics, {out}/schedule.csv")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ConfigError as e:  # e.g. an earlier run's files without --force
        print(f"plan_week: error: {e}", file=sys.stderr)
        sys.exit(2)
