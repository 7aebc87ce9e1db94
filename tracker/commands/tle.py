"""``tracker tle update|list|show``: fetch, list and inspect the element catalogue."""

from __future__ import annotations

import argparse
import statistics
import sys

from tracker.commands._common import add_time_args, clock_from_args, warn_element_age

FORMAT_CHOICES = ("tle", "json", "csv", "xml")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "tle", help="update, list and show element sets (TLE/OMM)",
        description="Manage the element cache: fetch CelesTrak groups, list what is cached, "
                    "show one satellite's elements and their age.")
    parser.add_argument("--cache-dir", metavar="DIR",
                        help="element cache directory (default: $TRACKER_CACHE_DIR/tle or the "
                             "user cache dir)")
    sub = parser.add_subparsers(dest="tle_command", metavar="ACTION", required=True)

    update = sub.add_parser("update", help="fetch CelesTrak groups or URLs into the cache")
    update.add_argument("sources", nargs="*", metavar="GROUP|URL",
                        help="CelesTrak GP groups or URLs (default: amateur weather stations "
                             "visual)")
    update.add_argument("--force", action="store_true",
                        help="fetch even if checked less than 2 hours ago, and accept a "
                             "download with far fewer sets than the cached copy")
    update.add_argument("--format", choices=FORMAT_CHOICES, default="tle",
                        help="element format to request for groups (default: tle)")
    update.add_argument("--base-url", metavar="URL",
                        help="GP query URL (default: $TRACKER_CELESTRAK_URL or CelesTrak)")
    update.add_argument("--timeout", type=float, default=20.0, metavar="S",
                        help="time limit for each download as a whole, seconds (default 20)")
    add_time_args(update)
    update.set_defaults(func=_update)

    listing = sub.add_parser("list", help="cached sources with counts and ages")
    add_time_args(listing)
    listing.set_defaults(func=_list)

    show = sub.add_parser("show", help="one satellite's element set and its age")
    show.add_argument("query", metavar="NAME|ID", help="name, NORAD id or designator")
    show.add_argument("--tle", action="append", default=[], metavar="FILE",
                      help="look in this TLE/OMM file instead of the catalogue (repeatable)")
    add_time_args(show)
    show.set_defaults(func=_show)


def _store(args: argparse.Namespace, base_url: str | None = None, timeout_s: float = 20.0):
    from tle.store import TleStore

    return TleStore(cache_dir=args.cache_dir, base_url=base_url, timeout_s=timeout_s,
                    clock=clock_from_args(args, manual=True))


def _update(args: argparse.Namespace) -> int:
    import math

    from tle.store import DEFAULT_GROUPS
    from tracker.errors import ConfigError

    if not (math.isfinite(args.timeout) and 0 < args.timeout <= 3600):
        raise ConfigError(f"--timeout {args.timeout:g} is invalid; give the seconds a "
                          "download may take, more than 0 and at most 3600 (default 20)")
    store = _store(args, args.base_url, args.timeout)

    def report(result) -> None:
        if result.status != "failed":
            print(f"{result.source.name:<12} {result.status:<13} {result.count:>6} sets  "
                  f"{result.message}")

    store.update(args.sources or DEFAULT_GROUPS, force=args.force, fmt=args.format,
                 on_result=report)
    print(f"cache: {store.cache_dir}")
    return 0


def _age(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} d"


def _list(args: argparse.Namespace) -> int:
    from tle.catalog import Catalog

    store = _store(args)
    infos = store.list()
    if infos:
        print(f"{'source':<14} {'sets':>6} {'checked':>9} {'element age':>12}  url")
        for info in infos:
            count = str(info.count) if info.count >= 0 else "?"
            epoch_age = ("-" if info.median_epoch_age_days is None
                         else f"{info.median_epoch_age_days:.1f} d")
            print(f"{info.name:<14} {count:>6} {_age(info.checked_age_s):>9} {epoch_age:>12}  "
                  f"{info.url or info.path}")
        print(f"cache: {store.cache_dir}")
        print()
        catalog = Catalog.default(store)
        print("the catalogue (every cached group and the bundled snapshot; the freshest set "
              "of each object wins):")
    else:
        catalog = Catalog.bundled_snapshot()
        print(f"no cached elements in {store.cache_dir}; using the bundled snapshot:")
    now_s = store.clock.timestamp()
    print(f"{'group':<14} {'sets':>6} {'element age':>12}  from")
    for name in catalog.groups:
        sets = list(catalog.group(name))
        median_age_d = statistics.median((now_s - es.epoch.timestamp()) / 86400.0 for es in sets)
        origin = " + ".join(catalog.group_origins(name)) or "-"
        print(f"{name:<14} {len(sets):>6} {median_age_d:>10.1f} d  {origin}")
    if catalog.bundled:
        print(f"note: {catalog.note}")
    return 0


def _show(args: argparse.Namespace) -> int:
    from tle.catalog import Catalog

    if args.tle:
        catalog = Catalog.load(args.tle, skip_bad=True,
                               on_warning=lambda m: print(f"tracker: warning: {m}",
                                                          file=sys.stderr))
    else:
        catalog = Catalog.default(_store(args))
    es = catalog.find(args.query)
    now = clock_from_args(args, manual=True).now()
    print(f"{es.name}  (NORAD {es.norad_id}, {es.intl_designator or 'no designator'})")
    print(f"epoch   {es.epoch:%Y-%m-%d %H:%M:%S} UTC, {es.age_days(now):.2f} days old")
    print(f"source  {es.source}:{es.line_no}")
    if es.line1 is not None:
        print(es.line1)
        print(es.line2)
    else:
        for key in ("MEAN_MOTION", "ECCENTRICITY", "INCLINATION", "RA_OF_ASC_NODE",
                    "ARG_OF_PERICENTER", "MEAN_ANOMALY", "BSTAR"):
            print(f"{key:<18} {es.omm[key]}")
    warn_element_age([es], now)
    if catalog.bundled and catalog.note:
        print(f"tracker: note: {catalog.note}", file=sys.stderr)
    return 0
