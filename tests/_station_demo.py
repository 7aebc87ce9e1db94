"""A station on a simulated ISS pass, for the status page's browser test, and the page's
screenshot in the docs:

    PYTHONPATH=. python tests/_station_demo.py                 # docs/img/station-status.png
    PYTHONPATH=. python tests/_station_demo.py --out page.png --at 2026-08-22T12:00Z

A G-5500 on the in-process GS-232B emulator follows two ISS passes on a ManualClock (virtual
time, a few seconds of CPU): the first to the end, the second up to its culmination. A
:class:`BoardFeed` and the small :class:`DemoStation` glue (what the station loop does:
the current pass, the schedule's states, the pass records) write onto a
:class:`StatusBoard`; the status page serves it and a headless Chromium
(``_browser.py``: Debian's ``chromium`` and ``chromium-driver``, and ``selenium``) takes
the picture. The clock stands still while it does, so the picture is the same on every
run. Needs the ``station`` extra (Flask, waitress).
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

from tracker.api import (
    Bench,
    Catalog,
    ManualClock,
    PassFollower,
    Station,
    StreamSettings,
    driver_limits,
    find_passes,
    make_controller,
    open_driver,
    preset,
    resolve_target,
)
from tracker.service.board import BoardFeed, StatusBoard
from tracker.station import HorizonMask
from tracker.timescale import iso_utc

REPO = Path(__file__).resolve().parents[1]   # the checkout
# a row of houses to the south-west, for the mask on the plot
STATION = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0,
                  mask=HorizonMask((0.0, 190.0, 200.0, 250.0, 260.0),
                                   (0.0, 0.0, 12.0, 12.0, 0.0)))
SPEC = preset("G-5500")
SETTINGS = StreamSettings(deadband_deg=4.0, cycle_s=2.0)


def pass_key(p: Any) -> str:
    return f"{p.target_name}@{iso_utc(p.aos.timestamp())}"


def pass_entry(p: Any, state: str = "planned", mode: str = "",
               path_step_s: float | None = None) -> dict[str, Any]:
    """A schedule entry for the pass ``p``; with ``path_step_s``, the current pass's entry:
    its sky path sampled every ``path_step_s``."""
    entry: dict[str, Any] = {
        "key": pass_key(p), "target": p.target_name, "aos_utc": iso_utc(p.aos.timestamp()),
        "los_utc": iso_utc(p.los.timestamp()), "max_el_deg": round(p.max_el_deg, 1),
        "priority": 1, "mode": mode, "state": state, "reason": ""}
    if path_step_s is not None:
        track = p.track(step_s=path_step_s)
        entry["path"] = [[round(float(a), 1), round(float(e), 1)]
                         for a, e in zip(track.az_deg, track.el_deg, strict=True) if e >= 0.0]
    return entry


def station_board(clock: Any, passes: list[Any], simulated: bool = True) -> StatusBoard:
    """A board for STATION with SPEC on the emulator and ``passes`` as its schedule."""
    mask = STATION.mask
    board = StatusBoard(
        clock, simulated=simulated,
        station={"name": STATION.name, "lat_deg": STATION.lat_deg, "lon_deg": STATION.lon_deg,
                 "alt_m": STATION.alt_m,
                 "mask": [[a, e] for a, e in zip(mask.az_deg, mask.min_el_deg, strict=True)] if mask
                 else []},
        rotator={"name": "G-5500", "protocol": "gs232b", "port": "emu://gs232b",
                 "az_min_deg": 0.0, "az_max_deg": SPEC.az_span_deg,
                 "el_max_deg": SPEC.el_max_deg})
    board.set_schedule(pass_entry(p) for p in passes)
    return board


class DemoStation:
    """What the station loop adds around a :class:`BoardFeed`: on each pass's plan, the
    current pass and its schedule state; at its end, the pass record."""

    def __init__(self, board: StatusBoard, passes: list[Any]):
        self.board = board
        self.feed = BoardFeed(board, SPEC)
        self.passes = passes
        self._current: Any = None
        self._predicted: float | None = None
        self._mode = ""

    def event(self, kind: str, **data: Any) -> None:
        self.feed.event(kind, **data)
        if kind != "state":
            return
        if data.get("state") == "plan":
            # the follower finds its next pass itself: the schedule's within a minute of it
            aos_s = datetime.fromisoformat(data["aos"]).timestamp()
            self._current = next((p for p in self.passes
                                  if abs(p.aos.timestamp() - aos_s) < 60.0), None)
            self._predicted, self._mode = data.get("predicted_max_error_deg"), data["mode"]
            if self._current is not None:
                self.board.set_current_pass(pass_entry(self._current, "tracking", self._mode,
                                                       path_step_s=10.0))
                self.board.update_pass(pass_key(self._current), state="tracking",
                                       mode=self._mode)
        elif data.get("state") == "pass_done" and self._current is not None:
            p = self._current
            self.board.add_pass({
                "key": pass_key(p), "target": p.target_name,
                "aos_utc": iso_utc(p.aos.timestamp()), "los_utc": iso_utc(p.los.timestamp()),
                "mode": self._mode, "outcome": "tracked", "reason": "",
                "predicted_max_error_deg": self._predicted,
                "measured_max_error_deg": data.get("max_error_deg"),
                "commands": data.get("commands"), "starts": None, "faults": 0})
            self.board.update_pass(pass_key(p), state="done")
            self.board.set_current_pass(None)
            self._current = None

    def status(self, st: Any) -> None:
        self.feed.status(st)


def follower(demo_station: DemoStation, clock: Any, bench: Bench, first: Any
             ) -> PassFollower:
    """A PassFollower of ISS on ``bench`` writing onto the demo's board."""
    def connect():
        return open_driver(bench.url, "gs232b", clock=clock, **driver_limits(SPEC))

    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    return PassFollower(iss, connect, SPEC, STATION, clock, SETTINGS,
                        events=demo_station.event, on_status=demo_station.status,
                        first=first)


def two_passes(at: datetime) -> tuple[list[Any], int]:
    """ISS passes from ``at`` for two and a half days, and the index of the first one after the
    first that climbs above 40 deg (the one to stop in)."""
    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    passes = find_passes(iss, STATION, at, at + timedelta(hours=60))
    k = next(i for i, p in enumerate(passes) if i >= 1 and p.max_el_deg >= 40.0)
    return passes, k


def parse_at(text: str) -> datetime:
    t = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return t if t.tzinfo else t.replace(tzinfo=timezone.utc)


def main(argv: list[str] | None = None) -> int:
    from _browser import chromium_missing, headless_chromium
    from selenium.webdriver.support.ui import WebDriverWait

    from tracker.service.web import StatusServer

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "docs" / "img" / "station-status.png"))
    ap.add_argument("--at", default="2026-08-22T13:00Z", help="search passes after this UTC")
    ap.add_argument("--size", default="1100x800", help="viewport, WIDTHxHEIGHT")
    args = ap.parse_args(argv)
    why = chromium_missing()
    if why:
        print(f"error: {why}", file=sys.stderr)
        return 1
    width, height = (int(v) for v in args.size.split("x"))

    passes, k = two_passes(parse_at(args.at))
    clock = ManualClock(passes[k - 1].aos - timedelta(minutes=2))
    board = station_board(clock, passes)
    epoch = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot()).elements.epoch
    board.set_elements([{"source": "bundled snapshot", "count": 1,
                         "age_h": round((clock.now() - epoch).total_seconds() / 3600.0, 1),
                         "checked_utc": iso_utc(clock.timestamp()), "note": "ISS only"}])
    stop_s = passes[k].tca.timestamp()
    with Bench(make_controller("gs232b", clock, rotator="G-5500")) as bench:
        f = follower(DemoStation(board, passes), clock, bench, passes[k - 1])
        try:
            f.run(passes=0, should_stop=lambda: clock.timestamp() >= stop_s)
        finally:
            f.close()
    with StatusServer(board, port=0) as server, headless_chromium(width, height) as browser:
        browser.get(server.url)
        WebDriverWait(browser, 30, poll_frequency=0.2).until(lambda d: d.execute_script(
            "return document.querySelectorAll('#passes-table tbody tr').length > 0 &&"
            " document.getElementById('ant-az').textContent !== '-'"))
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        browser.save_screenshot(args.out)
    print(f"wrote {args.out} ({Path(args.out).stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
