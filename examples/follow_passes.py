"""Follow the next two ISS passes with a G-5500 on the built-in GS-232B emulator, in virtual time.

    python examples/follow_passes.py
    python examples/follow_passes.py --at 2026-08-23T00:00Z --passes 3

The emulator runs in-process behind an ``emu://`` URL on a :class:`ManualClock` shared with
the tracking loop: every wait (the read-back cycle, the idle time between passes) is a jump
of that clock, so two passes and the park between them take a few seconds of CPU time.
:func:`follow_passes` pre-positions, tracks, parks, then re-plans the next pass from the
antenna's real position read back over the port; all-stop is the last thing on the wire.
Everything comes from :mod:`tracker.api`; swap the URL for ``/dev/ttyUSB0`` and the clock for
:class:`SystemClock` to drive a real rotator.
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timedelta, timezone

from tracker.api import (
    Bench,
    Catalog,
    ManualClock,
    Station,
    StreamSettings,
    TrackerError,
    describe_result,
    driver_limits,
    follow_passes,
    make_controller,
    next_pass,
    open_driver,
    preset,
    resolve_target,
)


def _parse_at(text: str) -> datetime:
    t = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return t if t.tzinfo else t.replace(tzinfo=timezone.utc)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--at", default="2026-08-22T12:00Z", help="search passes after this UTC")
    ap.add_argument("--passes", type=int, default=2, help="passes to follow in a row")
    args = ap.parse_args(argv)

    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    station = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0)
    spec = preset("G-5500")
    # a read-back every 2 s (the CLI's default is 0.5 s): the hour and a half between two
    # ISS passes is read back ~2700 times instead of ~11000, and the deadband still holds
    settings = StreamSettings(deadband_deg=4.0, cycle_s=2.0)
    try:
        first = next_pass(iss, station, _parse_at(args.at).timestamp())
    except TrackerError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    clock = ManualClock(first.aos - timedelta(minutes=3))

    def say(kind: str, **data) -> None:
        # the plan and result of each pass; the JSON-lines log of `tracker track --log`
        # gets every command and reply through this same sink
        if kind == "info":
            print(f"{clock.now():%H:%M:%S}  {data['text']}")
        elif kind == "command" and data.get("reason") == "park":
            print(f"{clock.now():%H:%M:%S}  park: az {data['az']:.0f} el {data['el']:.0f}")

    with Bench(make_controller("gs232b", clock, rotator="G-5500")) as bench:
        def connect():
            return open_driver(bench.url, "gs232b", clock=clock, **driver_limits(spec))

        results = follow_passes(iss, connect, spec, station, clock, settings,
                                passes=args.passes, first=first, events=say)
        last = bench.bytes_written().splitlines()[-1]
    for i, res in enumerate(results, 1):
        print(f"pass {i}: {describe_result(res, spec)}")
        if res.cause:
            print(f"  {res.cause}")
    print(f"last bytes on the wire: {last.decode()!r} (all-stop)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
