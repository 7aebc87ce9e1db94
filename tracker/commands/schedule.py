"""``tracker schedule SOURCE``: which passes one rotator should track when they overlap.

Priorities come from ``--priority NAME=N`` (repeatable) and/or ``--priorities FILE`` (lines
``NAME=N`` or ``NAME,N``); unlisted satellites get ``--default-priority`` (1; 0 skips them).
The schedule counts the slew from one pass's LOS to the next pass's AOS at the rotator's rates
(``--rotator``) and is exported like ``tracker batch`` (table/csv/json/ics, ``--out``).
"""

from __future__ import annotations

import argparse
import sys
import time

from tracker.commands._common import check_number_arg
from tracker.commands.batch import (
    add_batch_args,
    check_outputs,
    emit,
    find,
    load_elements,
    meta_of,
    plans_for,
    report_errors,
    rotator_spec,
    stations_from_args,
)


def register(sub) -> None:
    p = sub.add_parser("schedule", help="pick which overlapping passes one rotator tracks",
                       description="Find the passes of a catalogue over one station and "
                                   "choose, by priority, the ones a single rotator can track "
                                   "(counting the slew between passes).")
    add_batch_args(p)
    p.add_argument("--priority", action="append", default=[], metavar="NAME=N",
                   help="priority of a satellite (repeatable; higher wins, 0 = never)")
    p.add_argument("--priorities", metavar="FILE", help="file of NAME=N lines")
    p.add_argument("--default-priority", type=int, default=1, metavar="N",
                   help="priority of satellites not listed (default 1; 0 = only listed)")
    p.add_argument("--settle", type=float, default=0.0, metavar="S",
                   help="extra seconds to keep free between passes (default 0)")
    p.add_argument("--all", action="store_true", dest="show_all",
                   help="list skipped passes too (with chosen=false)")
    p.add_argument("--plot", metavar="PNG", help="timeline of chosen (solid) and skipped passes")
    p.set_defaults(func=run)


# A pause between passes longer than an hour is no "settle" any more (and 1e12 s is a typo).
MAX_SETTLE_S = 3600.0


def check_priority_names(args: argparse.Namespace, elements: list) -> None:
    """A ``--priority NAME=N`` must name a satellite of the catalogue (a typo would silently
    leave the satellite at the default priority); names from a priorities file that match
    nothing here only get a note (one file may serve several catalogues)."""
    import difflib

    from tracker.errors import ConfigError
    from tracker.pass_schedule import parse_priorities

    known = {es.name.strip().lower(): es.name for es in elements}
    for item in args.priority:
        name = next(iter(parse_priorities([item])))
        if name in known:
            continue
        close = difflib.get_close_matches(name, list(known), n=3)
        hint = (f"; did you mean {', '.join(repr(known[c]) for c in close)}?" if close else
                "; give the full name as `tracker passes` shows it")
        raise ConfigError(f"--priority {item}: no satellite named {name!r} in "
                          f"{args.source}{hint}")
    if args.priorities:
        unknown = sorted(set(parse_priorities([], args.priorities)) - set(known))
        if unknown:
            print(f"tracker: note: {args.priorities} names {len(unknown)} satellite(s) not in "
                  f"{args.source}: {', '.join(unknown[:5])}{' ...' if len(unknown) > 5 else ''}",
                  file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from tracker.commands._common import flag_first
    from tracker.errors import ConfigError
    from tracker.export import error_records, pass_records, render
    from tracker.pass_schedule import parse_priorities, schedule_passes

    if args.default_priority < 0:
        raise ConfigError("--default-priority must be 0 or more")
    check_number_arg(args, "settle", 0.0, MAX_SETTLE_S, "seconds")
    try:
        priorities = parse_priorities(args.priority, args.priorities)
    except ConfigError as e:
        raise flag_first(e, "priority", "--priority") from None
    check_outputs(args)
    t0 = time.perf_counter()
    stations = stations_from_args(args)
    if len(stations) != 1:
        raise ConfigError(f"a schedule is for one station; {args.stations} lists "
                          f"{len(stations)} ({', '.join(s.name for s in stations[:5])}...); "
                          f"give a file with one station or use --station/--lat/--lon")
    elements = load_elements(args.source)
    check_priority_names(args, elements)
    table, start = find(args, elements, stations)
    if not args.rotator:
        args.rotator = None
    spec = rotator_spec(args)
    records = pass_records(table, plans_for(args, table, elements))
    sched = schedule_passes(records, spec, priorities, args.default_priority, args.settle)
    elapsed = time.perf_counter() - t0
    chosen = set(sched.chosen)
    out = records if args.show_all else records.take(sched.chosen)
    report_errors(table.errors)
    meta = meta_of(args, table, start, elapsed)
    meta.update(rotator=spec.name, total_priority=sched.total_priority,
                chosen=len(sched.chosen), candidates=len(records))
    text = render(args.format, out, meta=meta, errors=error_records(table.errors),
                  stamp_s=start.timestamp(), name=f"{args.source} schedule")
    if args.plot:
        from tracker.plot import timeline_plot

        path = timeline_plot(records, args.plot, start.timestamp(), table.end.timestamp(),
                             title=f"schedule for {spec.name}", chosen=chosen,
                             force=args.force, label="--plot")
        print(f"tracker: wrote {path}", file=sys.stderr)
    emit(args, text)
    print(f"tracker: scheduled {len(sched.chosen)} of {len(records)} passes for {spec.name} "
          f"(total priority {sched.total_priority})", file=sys.stderr)
    return 0
