"""Character pacing in :class:`tracker.protocols.link.ByteLink`: each byte waits for a running
deadline on the port's clock, so the overshoot of one sleep never adds to the next."""

from __future__ import annotations

from datetime import datetime, timezone

import pytest
from _virtual import manual_clock, virtual_rig

from tracker.clock import ManualClock
from tracker.emulator import Gs232Controller
from tracker.mount import preset
from tracker.protocols.gs232 import Gs232Driver
from tracker.protocols.link import ByteLink
from tracker.steptable import PROFILES, tables_from_points

T0_S = 1787400000.0
EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)   # clock readings near 0: exact to 1e-15 s
CHAR_S = 10 / 9600          # one 8N1 character at 9600 Bd
OVERSHOOT_S = 1e-4          # what a real sleep adds, roughly


class OvershootingClock(ManualClock):
    """A ManualClock whose every sleep lasts ``OVERSHOOT_S`` longer than asked, as a real
    one does."""

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self.advance(seconds + OVERSHOOT_S)


class RecordingPort:
    """A port-like double on ``clock``: records when each byte is written."""

    def __init__(self, clock):
        self.clock = clock
        self.times: list[float] = []
        self.data = bytearray()

    def write(self, data: bytes) -> int:
        self.times.extend(self.clock.monotonic() for _ in data)
        self.data += data
        return len(data)

    def flush(self) -> None:
        pass


def test_each_byte_goes_at_its_deadline_and_overshoot_does_not_accumulate():
    clock = OvershootingClock(EPOCH)
    port = RecordingPort(clock)
    link = ByteLink(port, pace_char_s=CHAR_S)
    assert link.io_clock is clock
    data = b"W1 " + b"123 045 " * 500 + b"\r"
    start = clock.monotonic()
    link.write(data)
    assert bytes(port.data) == data
    assert port.times[0] == start
    # byte i leaves at start + i * char time, late by at most one sleep's overshoot
    for i, t in enumerate(port.times[1:], start=1):
        assert t == pytest.approx(start + i * CHAR_S + OVERSHOOT_S, abs=1e-9)
    # the whole write: its wire time plus one overshoot, not one per byte
    assert clock.monotonic() - start == pytest.approx(len(data) * CHAR_S + OVERSHOOT_S,
                                                      abs=1e-9)


def test_an_exact_clock_paces_exactly_to_the_wire_time():
    clock = ManualClock(EPOCH)
    port = RecordingPort(clock)
    link = ByteLink(port, pace_char_s=CHAR_S)
    link.write(b"C2\r")
    assert port.times == pytest.approx([0.0, CHAR_S, 2 * CHAR_S], abs=1e-12)
    assert clock.monotonic() == pytest.approx(3 * CHAR_S, abs=1e-12)


def test_the_driver_paces_a_table_upload_at_the_baud_rate_on_emu():
    clock = manual_clock(T0_S)
    rig = virtual_rig(Gs232Controller("gs232b", preset("G-5500"), clock))
    try:
        drv = Gs232Driver.from_url(rig.url, "gs232b", pace_char_s=CHAR_S, clock=clock)
        drv.stop_on_exit = False
        table = tables_from_points("W", 1, [(i % 451, i % 181) for i in range(1900)],
                                   PROFILES["gs232b"])
        before = len(rig.written())
        t0 = clock.monotonic()
        drv.upload_table(1, table.points)
        sent = len(rig.written()) - before
        elapsed = clock.monotonic() - t0
        drv.close()
        assert rig.ctl.table is not None and len(rig.ctl.table.points) == 1900
        assert sent > 15000
        # paced to the byte (the clock reads POSIX seconds near 1.8e9: 2.4e-7 s resolution)
        assert elapsed == pytest.approx(sent * CHAR_S, abs=1e-6)
    finally:
        rig.close()
