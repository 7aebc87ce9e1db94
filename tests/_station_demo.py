"""A real station (:class:`~tracker.service.runner.StationService`) on simulated ISS passes,
for the status page's browser test and the page's screenshot in the docs:

    PYTHONPATH=. python tests/_station_demo.py                 # docs/img/station-status.png
    PYTHONPATH=. python tests/_station_demo.py --out page.png --at 2026-08-22T12:00Z

The station (Delft, a mask of houses to the south-west) tracks the ISS with a G-5500 on the
in-process GS-232B emulator, in virtual time. For the picture its clock stops at the
culmination of the first pass above 40 deg after another one (so "last passes" has a row),
with the station tracking; the status page serves its board and a headless Chromium
(``_browser.py``: Debian's ``chromium`` and ``chromium-driver``, and ``selenium``) takes the
picture. The clock stands still while it does, so the picture is the same on every run.
Needs the ``station`` extra (Flask, waitress).
"""

from __future__ import annotations

import argparse
import sys
import threading
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

from tracker.api import (
    Catalog,
    LockstepClock,
    Station,
    StreamSettings,
    controller,
    find_passes,
    preset,
    resolve_target,
)
from tracker.config import ScheduleSettings
from tracker.service.board import StatusBoard
from tracker.service.runner import StationService
from tracker.service.simulate import emulated
from tracker.station import HorizonMask

REPO = Path(__file__).resolve().parents[1]   # the checkout
# a row of houses to the south-west, for the mask on the plot
STATION = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0,
                  mask=HorizonMask((0.0, 190.0, 200.0, 250.0, 260.0),
                                   (0.0, 0.0, 12.0, 12.0, 0.0)))
SPEC = preset("G-5500")
SETTINGS = StreamSettings(deadband_deg=4.0, cycle_s=2.0)
SCHEDULE = ScheduleSettings(targets={"ISS (ZARYA)": 1}, mode="stream", horizon_h=24.0)


def station(clock: Any) -> tuple[StationService, Any]:
    """The demo station on ``clock`` and its emulator's bench (close it after)."""
    mask = STATION.mask
    board = StatusBoard(
        clock, simulated=True,
        station={"name": STATION.name, "lat_deg": STATION.lat_deg, "lon_deg": STATION.lon_deg,
                 "alt_m": STATION.alt_m,
                 "mask": [[a, e] for a, e in zip(mask.az_deg, mask.min_el_deg, strict=True)]
                 if mask else []},
        rotator={"name": SPEC.name, "protocol": "gs232b", "port": "built-in emulator",
                 "az_min_deg": 0.0, "az_max_deg": SPEC.az_span_deg,
                 "el_max_deg": SPEC.el_max_deg})
    bench, connect = emulated(controller("gs232b"), SPEC, clock)
    service = StationService(station=STATION, spec=SPEC, controller=controller("gs232b"),
                             connect=connect, clock=clock, schedule=SCHEDULE, stream=SETTINGS,
                             board=board, catalog=Catalog.bundled_snapshot())
    return service, bench


def high_pass(at: datetime) -> tuple[Any, Any]:
    """The first ISS pass after ``at`` that climbs above 40 deg with a pass before it, and
    that pass before it."""
    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    passes = [p for p in find_passes(iss, STATION, at, at + timedelta(hours=36))
              if p.max_el_deg >= SCHEDULE.min_max_el_deg]
    k = next(i for i, p in enumerate(passes) if i >= 1 and p.max_el_deg >= 40.0)
    return passes[k - 1], passes[k]


class FreezingClock(LockstepClock):
    """Virtual time that stops at ``freeze_s`` (``frozen`` is set) until ``thaw``."""

    def __init__(self, start: datetime, freeze_s: float):
        super().__init__(start)
        self.freeze_s = freeze_s
        self.frozen = threading.Event()
        self.thaw = threading.Event()

    def sleep(self, seconds: float) -> None:
        if self.timestamp() >= self.freeze_s and not self.thaw.is_set():
            self.frozen.set()
            self.thaw.wait()
        super().sleep(seconds)


def run_in_thread(service: StationService, stop: threading.Event,
                  failure: list[BaseException]) -> threading.Thread:
    """The service's loop on a thread of its own until ``stop``; an error lands in
    ``failure``."""
    def run() -> None:
        try:
            service.run(should_stop=stop.is_set)
        except BaseException as e:   # reported by the caller, not lost in the thread
            failure.append(e)

    loop = threading.Thread(target=run, name="station", daemon=True)
    loop.start()
    return loop


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

    before, high = high_pass(parse_at(args.at))
    clock = FreezingClock(before.aos - timedelta(minutes=10), high.tca.timestamp())
    service, bench = station(clock)
    stop, failure = threading.Event(), []
    loop = run_in_thread(service, stop, failure)
    try:
        if not clock.frozen.wait(300):
            print(f"error: the station did not reach {high.tca} ({failure})", file=sys.stderr)
            return 1
        board = service.board
        with StatusServer(board, port=0) as server, \
                headless_chromium(width, height) as browser:
            browser.get(server.url)
            WebDriverWait(browser, 30, poll_frequency=0.2).until(lambda d: d.execute_script(
                "return document.querySelectorAll('#passes-table tbody tr').length > 0 &&"
                " document.getElementById('ant-az').textContent !== '-'"))
            Path(args.out).parent.mkdir(parents=True, exist_ok=True)
            browser.save_screenshot(args.out)
    finally:
        stop.set()
        clock.thaw.set()
        loop.join(60)
        bench.close()
    if failure:
        raise failure[0]
    print(f"wrote {args.out} ({Path(args.out).stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
