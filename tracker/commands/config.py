"""``tracker config init|show|path``: write the commented template, print the effective config."""

from __future__ import annotations

import argparse

from tracker.commands._common import add_config_arg, add_station_args


def register(sub) -> None:
    p = sub.add_parser("config", help="create or show the config file",
                       description="Manage the TOML config file (station, rotators, "
                                   "tracking defaults).")
    csub = p.add_subparsers(dest="config_command", metavar="ACTION")
    init = csub.add_parser("init", help="write a commented template config file",
                           description="Write a commented config file with your station: "
                                       "--lat/--lon (and --alt) or a Maidenhead --locator.")
    init.add_argument("--force", action="store_true",
                      help="overwrite an existing file (otherwise it is never touched)")
    init.add_argument("--lat", type=float, metavar="DEG", help="station latitude, degrees north")
    init.add_argument("--lon", type=float, metavar="DEG", help="station longitude, degrees east")
    init.add_argument("--alt", type=float, default=0.0, metavar="M",
                      help="station altitude above the ellipsoid, m (default 0)")
    init.add_argument("--locator", metavar="LOC",
                      help="Maidenhead locator (JO22, JO22xb, ...) instead of --lat/--lon")
    add_config_arg(init)
    init.set_defaults(func=run_init)
    show = csub.add_parser("show", help="print the effective config as TOML "
                                        "(file + command-line overrides)")
    add_station_args(show)
    show.set_defaults(func=run_show)
    path = csub.add_parser("path", help="print where the config file is read from")
    add_config_arg(path)
    path.set_defaults(func=run_path)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def _path(args: argparse.Namespace):
    from pathlib import Path

    from tracker.config import default_config_path

    return Path(args.config).expanduser() if args.config else default_config_path()


def run_init(args: argparse.Namespace) -> int:
    from tracker.commands._common import in_flag_terms
    from tracker.config import template_text, write_template
    from tracker.errors import ConfigError

    if args.locator is not None and (args.lat is not None or args.lon is not None):
        raise ConfigError("give either --locator or --lat/--lon, not both")
    if (args.lat is None) != (args.lon is None):
        raise ConfigError("give both --lat and --lon (or a Maidenhead --locator)")
    try:
        text = template_text(args.lat, args.lon, args.alt, args.locator)
    except ConfigError as e:
        raise ConfigError(f"command line: {e}") from None
    try:
        path = write_template(_path(args), force=args.force, text=text)
    except ConfigError as e:
        raise in_flag_terms(e, [("another path", "another --config path")]) from None
    if args.locator is None and args.lat is None:
        print(f"wrote {path} with the placeholder station 52.0 N 4.4 E; set [station] "
              f"lat_deg/lon_deg (or locator) there, or run `tracker config init --locator LOC "
              f"--force` (or --lat/--lon); commands say so until then")
    else:
        print(f"wrote {path}; edit [rotator.home] and [tracking] for your rotator")
    return 0


def run_show(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from tracker.commands._common import config_from_args, station_from_args

    config = config_from_args(args)
    station = station_from_args(args, quiet=True)
    if config.station_is_default and station == config.station:
        print("# no config file: built-in default station; run `tracker config init`")
    print(replace(config, station=station).to_toml(), end="")
    return 0


def run_path(args: argparse.Namespace) -> int:
    path = _path(args)
    print(f"{path}{'' if path.exists() else '  (does not exist yet)'}")
    return 0
