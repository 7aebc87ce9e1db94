"""Clocks: simulated time scales, pauses, skips and never runs backwards."""

import time
from datetime import datetime, timezone

import pytest

from tracker.clock import ManualClock, SimClock, utc

START = utc(2026, 8, 23, 2, 0)


def test_simclock_runs_speed_times_faster():
    clock = SimClock(START, speed=100.0)
    t0 = clock.timestamp()
    time.sleep(0.05)
    elapsed = clock.timestamp() - t0
    assert 4.0 <= elapsed <= 30.0          # 0.05 s real at 100x, with scheduler slack
    assert clock.now().tzinfo is timezone.utc


def test_paused_simclock_stands_still_and_resumes_without_a_jump():
    clock = SimClock(START, speed=1000.0)
    clock.pause()
    frozen = clock.timestamp()
    time.sleep(0.03)
    assert clock.timestamp() == frozen
    clock.resume()
    assert 0.0 <= clock.timestamp() - frozen < 20.0   # picks up where it stopped


def test_skip_jumps_forward_only():
    clock = SimClock(START, speed=1.0)
    clock.pause()
    before = clock.timestamp()
    clock.skip(3600.0)
    assert clock.timestamp() - before == pytest.approx(3600.0)
    clock.skip(-50.0)
    assert clock.timestamp() - before == pytest.approx(3600.0)


def test_clocks_refuse_naive_times_and_bad_speeds():
    with pytest.raises(ValueError, match="timezone-aware"):
        SimClock(datetime(2026, 8, 23), speed=1.0)
    with pytest.raises(ValueError, match="speed"):
        SimClock(START, speed=0.0)
    with pytest.raises(ValueError, match="timezone-aware"):
        ManualClock(datetime(2026, 8, 23))


def test_manual_clock_moves_only_when_told():
    clock = ManualClock(START)
    t0 = clock.timestamp()
    time.sleep(0.01)
    assert clock.timestamp() == t0
    clock.sleep(12.5)
    assert clock.timestamp() - t0 == 12.5
    assert clock.monotonic() == 12.5
