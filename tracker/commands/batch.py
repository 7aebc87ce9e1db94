"""``tracker batch SOURCE``: every pass of a catalogue over one or many stations.

``SOURCE`` is a TLE/3LE/OMM file, a catalogue group (``amateur``, ``weather``, ...) or ``all``.
Stations come from ``--stations FILE`` (the config's station fields as CSV
``name,lat_deg,lon_deg[,alt_m[,min_el_deg]]`` or TOML ``[[station]]`` tables) or the usual
station options. Output: ``--format table|csv|json|ics`` to stdout or ``--out FILE`` (written
atomically), or ``--format parquet`` (with ``--out``; needs pyarrow; with ``--dask`` and an
``--out`` folder, ``DIR/``, each worker writes its chunk's file). The result is written in
parts of :data:`ROWS_PER_PART` passes, so the text of a whole-catalogue run is never held at
once (iCalendar excepted). ``--rotator NAME`` adds the planner's
summary (mode, predicted max error, pre-position time) to passes above ``--min-max-el``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Iterable, Iterator
from datetime import timedelta
from itertools import chain
from pathlib import Path

from tracker.commands._common import (
    add_rotator_args,
    add_station_args,
    add_time_args,
    check_number_arg,
    clock_from_args,
    rotator_from_args,
    station_from_args,
    warn_element_age,
)

MAX_SKY_PLOTS = 50
# Passes converted to records and written at a time: bounds the export's memory (a part's
# columns and its text) whatever the catalogue size; the finder's table itself is a compact
# numpy array (64 bytes per pass).
ROWS_PER_PART = 20_000
FORMATS = ("table", "csv", "json", "ics")


def add_batch_args(p: argparse.ArgumentParser, formats: tuple[str, ...] = FORMATS) -> None:
    """Options shared by ``batch`` and ``schedule``."""
    p.add_argument("source", metavar="CATALOG|GROUP",
                   help="TLE/3LE/OMM file, catalogue group (amateur, weather, ...) or 'all'")
    p.add_argument("--stations", metavar="FILE",
                   help="stations file: CSV name,lat_deg,lon_deg[,alt_m[,min_el_deg]] (or a "
                        "header row naming the columns) or TOML [[station]] tables")
    p.add_argument("--days", type=float, default=1.0, help="window length in days (default 1)")
    p.add_argument("--min-max-el", type=float, default=0.0, metavar="DEG", dest="min_max_el",
                   help="keep passes whose max elevation reaches DEG (default 0)")
    vis = p.add_mutually_exclusive_group()
    vis.add_argument("--sunlit", action="store_true", help="only passes with the satellite lit")
    vis.add_argument("--visible", action="store_true",
                     help="only passes lit while the station is dark (Sun below -6 deg)")
    p.add_argument("--format", choices=formats, default="table")
    p.add_argument("--out", metavar="FILE", help="write here (atomically) instead of stdout")
    p.add_argument("--force", action="store_true",
                   help="replace existing --out/--plot files (otherwise they are never touched)")
    add_rotator_args(p)
    p.add_argument("--dask", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster (a local one when no scheduler ADDRESS)")
    p.add_argument("--workers", type=int, default=1,
                   help="local processes to split the satellites over (default 1)")
    p.add_argument("--step", type=float, default=480.0, metavar="S",
                   help="fine sampling step of the finder in seconds (default 480)")
    add_station_args(p)
    add_time_args(p)


def register(sub) -> None:
    p = sub.add_parser("batch", help="all passes of a catalogue over one or many stations",
                       description="Find every pass of a catalogue (or group) over one or "
                                   "more stations, with plan summaries and CSV/JSON/iCalendar "
                                   "export.")
    add_batch_args(p, (*FORMATS, "parquet"))
    p.add_argument("--plot", metavar="PNG",
                   help="also draw a timeline of the passes per satellite (.png/.svg)")
    p.add_argument("--sky-plots", metavar="DIR", dest="sky_plots",
                   help=f"with --rotator: a polar sky plot per planned pass in DIR (first "
                        f"{MAX_SKY_PLOTS})")
    p.set_defaults(func=run)


def load_elements(source: str) -> list:
    """ElementSets from a file path, a catalogue group name, or ``all``."""
    from tle.catalog import Catalog
    from tle.elements import load_file
    from tracker.errors import ConfigError

    def warn(message: str) -> None:
        print(f"tracker: warning: {message}", file=sys.stderr)

    path = Path(source)
    if path.exists() and not path.is_dir():  # special files: load_file says what is wrong
        sets = load_file(path, skip_bad=True, on_warning=warn)
    elif path.is_dir() and (any(c in source for c in "/\\") or path.suffix):
        raise ConfigError(f"{source} is a directory; give a TLE/3LE/OMM file or a group name "
                          f"such as 'amateur'")
    elif any(c in source for c in "/\\") or path.suffix:
        raise ConfigError(f"cannot read {source}: no such file (or give a group name such as "
                          f"'amateur')")
    else:
        catalog = Catalog.default(on_warning=warn)
        sets = list(catalog if source.lower() == "all" else catalog.group(source))
    if not sets:
        raise ConfigError(f"{source}: no element sets found")
    return sets


def usable_elements(elements: list, start, end) -> list:
    """The element sets close enough to their epoch for the window; the others are named in
    one note, and a window none of them reaches is an error."""
    from tracker.batch import split_by_epoch
    from tracker.errors import PropagationError
    from tracker.targets import MAX_PROPAGATION_DAYS

    near, far = split_by_epoch(elements, start.timestamp(), end.timestamp())
    if not far:
        return near
    epochs = sorted(es.epoch for es in far)
    span = f"epochs {epochs[0]:%Y-%m-%d} .. {epochs[-1]:%Y-%m-%d}"
    if not near:
        raise PropagationError(
            f"the window {start:%Y-%m-%d} .. {end:%Y-%m-%d} is more than "
            f"{MAX_PROPAGATION_DAYS:.0f} days from every element set's epoch ({span}); "
            f"choose a time near the epochs or use elements from near that date")
    names = ", ".join(es.name for es in far[:5]) + (" ..." if len(far) > 5 else "")
    print(f"tracker: note: left out {len(far)} satellite(s) whose elements are more than "
          f"{MAX_PROPAGATION_DAYS:.0f} days from the window ({span}): {names}",
          file=sys.stderr)
    return near


def stations_from_args(args: argparse.Namespace) -> list:
    from tracker.batch import load_stations

    if args.stations:
        return load_stations(args.stations)
    return [station_from_args(args, quiet=args.format != "table")]


def search_window(args: argparse.Namespace, elements: list):
    """The checked options' window (start, end); element sets too far from their epoch for
    it are removed from ``elements`` (in place: the table's satellite indices must index the
    caller's list too, for plans_for), the others' age is warned about."""
    from tracker.errors import ConfigError

    if not (0 < args.days <= 60):
        raise ConfigError(f"--days {args.days}: allowed more than 0 and at most 60")
    if not (1 <= args.workers <= 64):
        raise ConfigError(f"--workers {args.workers}: allowed 1 to 64")
    check_number_arg(args, "min_max_el", 0.0, 90.0, "degrees")
    start = clock_from_args(args, manual=True).now()
    end = start + timedelta(days=args.days)
    elements[:] = usable_elements(elements, start, end)
    warn_element_age(elements, start)
    return start, end


def find(args: argparse.Namespace, elements: list, stations: list):
    """Run the finder (local or Dask) for the parsed options; returns (table, start).

    Element sets too far from their epoch for the window are removed from ``elements``."""
    from tracker.batch import PassTable

    parts, start = find_parts(args, elements, stations)
    return PassTable.concat(list(parts)), start


def find_parts(args: argparse.Namespace, elements: list, stations: list):
    """:func:`find` with the table in parts (``iter_passes_batch``): returns (parts, start);
    the search runs when the first part is taken, and every part carries its errors."""
    from tracker.batch import find_passes_dask, iter_passes_batch, satrecs_of, select_passes
    from tracker.commands._common import flag_first
    from tracker.errors import ConfigError

    start, end = search_window(args, elements)
    if args.dask is not None:
        try:
            parts = iter([find_passes_dask(elements, stations, start, end, args.min_el,
                                           address=args.dask or None, step_s=args.step)])
        except ConfigError as e:
            raise flag_first(flag_first(e, "find_passes_dask", "--dask"), "address",
                             "--dask") from None
    else:
        satrecs, names = satrecs_of(elements)
        parts = iter_passes_batch(satrecs, names, stations, start, end, args.min_el,
                                  step_s=args.step, workers=args.workers)
    return (select_passes(t, args.min_max_el, only_of(args)) for t in parts), start


def only_of(args: argparse.Namespace) -> str | None:
    """``--sunlit`` / ``--visible`` as the finder's filter name."""
    return "visible" if args.visible else "sunlit" if args.sunlit else None


def rotator_spec(args: argparse.Namespace):
    """``--rotator NAME``: a [rotator.NAME] config section or a preset."""
    return rotator_from_args(args)


def plans_for(args: argparse.Namespace, table, elements) -> list | None:
    from tracker.errors import ConfigError

    sky_dir = getattr(args, "sky_plots", None)
    if not args.rotator:
        if sky_dir:
            raise ConfigError("--sky-plots needs --rotator (the plots show the planned path)")
        return None
    from tracker.batch import plan_summaries

    spec = rotator_spec(args)
    satrecs = {}
    for i in sorted(set(table.passes["sat"].tolist())):
        satrecs[i] = elements[i].satrec()
    on_plan = None
    if sky_dir:
        from tracker.plot import sky_plot
        from tracker.timescale import iso_utc

        folder = Path(sky_dir)
        if not folder.is_dir():
            raise ConfigError(f"--sky-plots {folder}: no such folder")
        drawn = []

        def on_plan(i, plan, station):
            if len(drawn) >= MAX_SKY_PLOTS:
                return
            row = table.passes[i]
            stem = "".join(c if c.isalnum() or c in "-_" else "_" for c in
                           f"{table.names[int(row['sat'])]}_{station.name}_"
                           f"{iso_utc(float(row['aos_s']))}")
            drawn.append(sky_plot(plan, station, folder / f"{stem}.png", force=args.force,
                                  label="--sky-plots"))

    return plan_summaries(table, satrecs, spec, args.min_max_el, on_plan=on_plan)


def check_outputs(args: argparse.Namespace) -> None:
    """Refuse unusable output paths before the (possibly long) pass search."""
    from tracker.errors import ConfigError
    from tracker.files import check_output
    from tracker.plot import check_plot_path, require_matplotlib

    if args.format == "parquet":
        from tracker.export import require_pyarrow

        if not args.out:
            raise ConfigError("--format parquet needs --out FILE (Parquet is not written to "
                              "the terminal)")
        require_pyarrow()
    if partitioned(args):
        check_partitioned(args)
    elif args.out:
        check_output(args.out, force=args.force, label="--out")
    if getattr(args, "plot", None):
        check_plot_path(args.plot, force=args.force, label="--plot")
    if getattr(args, "sky_plots", None):
        require_matplotlib()


def partitioned(args: argparse.Namespace) -> bool:
    """``--format parquet --dask --out DIR/`` (a trailing slash, or a folder that exists):
    the workers write one file each into DIR."""
    out = getattr(args, "out", None)
    return (getattr(args, "format", None) == "parquet" and args.dask is not None
            and bool(out) and (out.endswith(("/", os.sep)) or Path(out).is_dir()))


def check_partitioned(args: argparse.Namespace) -> None:
    from tracker.batch.output import check_output_dir
    from tracker.errors import ConfigError

    for flag, value in (("--plot", getattr(args, "plot", None)),
                        ("--sky-plots", getattr(args, "sky_plots", None))):
        if value:
            raise ConfigError(f"{flag} needs every pass in this process; it cannot be drawn "
                              f"with a partitioned --out folder (give --out a file name)")
    check_output_dir(args.out, force=args.force, label="--out")


def run_partitioned(args: argparse.Namespace) -> int:
    """The workers find and write the passes, one Parquet file per chunk in the --out
    folder; this process sees only counts and errors."""
    from tracker.batch import write_passes_dask
    from tracker.commands._common import flag_first
    from tracker.errors import ConfigError

    t0 = time.perf_counter()
    elements = load_elements(args.source)
    stations = stations_from_args(args)
    start, end = search_window(args, elements)
    meta = window_meta(args, stations, len(elements), start, end)
    try:
        result = write_passes_dask(
            elements, stations, start, end, args.out, args.min_el,
            min_max_el_deg=args.min_max_el, only=only_of(args),
            rotator=rotator_spec(args) if args.rotator else None, meta=meta,
            force=args.force, address=args.dask or None, step_s=args.step,
            rows_per_group=ROWS_PER_PART)
    except ConfigError as e:
        raise flag_first(flag_first(e, "write_passes_dask", "--dask"), "address",
                         "--dask") from None
    elapsed = time.perf_counter() - t0
    report_errors(result.errors)
    parts = len(result.files)
    print(f"tracker: wrote {result.folder} ({parts} part{'s' if parts != 1 else ''})",
          file=sys.stderr)
    print(f"tracker: {result.n_passes} passes of {len(elements)} satellites over "
          f"{len(stations)} station(s) in {elapsed:.1f} s", file=sys.stderr)
    return 0


def emit(args: argparse.Namespace, text: str | Iterable[str]) -> None:
    """Write the output (whole, or in parts as they are produced) to ``--out`` or stdout."""
    from tracker.files import write_atomic

    if args.out:
        path = write_atomic(args.out, text, force=args.force, label="--out")
        print(f"tracker: wrote {path}", file=sys.stderr)
    else:
        for part in [text] if isinstance(text, str) else text:
            sys.stdout.write(part)


def record_parts(table, plans, rows: int | None = None) -> Iterator:
    """The table's pass records, ``rows`` (default :data:`ROWS_PER_PART`) passes at a time in
    table order (one empty part for an empty table)."""
    from tracker.export import pass_records

    rows = rows or ROWS_PER_PART
    for a in range(0, max(len(table), 1), rows):
        part = slice(a, a + rows)
        yield pass_records(table.select(part), None if plans is None else plans[part])


def write_output(args: argparse.Namespace, tables: Iterable[tuple], meta: dict, start,
                 errors: list[dict]) -> None:
    """``--format``/``--out`` for a batch result given as consecutive (table, plans) parts,
    written part by part."""
    from tracker.export import render_chunks, write_parquet

    parts = (records for table, plans in tables for records in record_parts(table, plans))
    if args.format == "parquet":
        emit(args, lambda f: write_parquet(parts, f, meta=meta, errors=errors))
        return
    emit(args, render_chunks(args.format, parts, meta=meta, errors=errors,
                             stamp_s=start.timestamp(), name=f"{args.source} passes"))


def meta_of(args, table, start, elapsed_s: float) -> dict:
    return dict(window_meta(args, table.stations, len(table.names), start, table.end),
                elapsed_s=round(elapsed_s, 3))


def window_meta(args, stations, n_satellites: int, start, end) -> dict:
    """The document's ``meta`` for a run over ``stations`` (all but ``elapsed_s``)."""
    from tracker.export import station_meta
    from tracker.timescale import iso_utc

    return {"source": args.source, "start": iso_utc(start), "end": iso_utc(end),
            "stations": [station_meta(s) for s in stations],
            "min_el_deg": args.min_el, "min_max_el_deg": args.min_max_el,
            "filter": only_of(args), "rotator": args.rotator, "satellites": n_satellites}


def report_errors(errors) -> None:
    """One note naming the satellites SGP4 could not propagate (a table's ``errors``)."""
    if not errors:
        return
    shown = ", ".join(f"{e.name} ({e.message})" for e in errors[:3])
    more = f" and {len(errors) - 3} more" if len(errors) > 3 else ""
    print(f"tracker: note: SGP4 could not propagate {len(errors)} satellite(s) for the "
          f"whole window (decayed or bad elements): {shown}{more}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    check_outputs(args)
    if partitioned(args):
        return run_partitioned(args)
    t0 = time.perf_counter()
    elements = load_elements(args.source)
    stations = stations_from_args(args)
    parts, start = find_parts(args, elements, stations)
    table = next(parts)  # the search runs here
    whole = bool(args.rotator or args.plot or args.format == "ics")
    if whole:
        from tracker.batch import PassTable

        table = PassTable.concat([table, *parts])
    plans = plans_for(args, table, elements)
    elapsed = time.perf_counter() - t0
    report_errors(table.errors)
    if args.plot:
        from tracker.export import pass_records
        from tracker.plot import timeline_plot

        path = timeline_plot(pass_records(table, plans), args.plot, start.timestamp(),
                             table.end.timestamp(), title=f"{args.source}: {len(table)} passes",
                             force=args.force, label="--plot")
        print(f"tracker: wrote {path}", file=sys.stderr)
    from tracker.export import error_records

    written = [0]

    def tables():
        # Without plans, plot or iCalendar the parts are written as the finder gives them
        # (one held at a time); empty parts are left out unless the whole result is empty.
        for part in [table] if whole else chain([table], parts):
            if whole or len(part):
                written[0] += len(part)
                yield part, plans
        if not written[0] and not whole:
            yield table.select(slice(0, 0)), None

    write_output(args, tables(), meta_of(args, table, start, elapsed), start,
                 error_records(table.errors))
    print(f"tracker: {written[0]} passes of {len(elements)} satellites over "
          f"{len(stations)} station(s) in {elapsed:.1f} s", file=sys.stderr)
    return 0
