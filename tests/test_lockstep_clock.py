"""LockstepClock: virtual time shared by concurrent loops (the two-antenna run)."""

from __future__ import annotations

import threading
import time
from datetime import datetime, timezone

from tracker.clock import LockstepClock

START = datetime(2026, 8, 23, tzinfo=timezone.utc)


def _run(clock, plans):
    """One thread per (name, period_s, count): sleep, record the time, 'work' a little (real
    time) and check the clock did not move meanwhile; leave when done."""
    seen: list[tuple[float, str]] = []
    moved: list[str] = []

    def party(name, period_s, count):
        try:
            for _ in range(count):
                clock.sleep(period_s)
                t = clock.monotonic()
                seen.append((t, name))
                time.sleep(0.002)                 # real work takes real time ...
                if clock.monotonic() != t:        # ... but no virtual time passes
                    moved.append(name)
        finally:
            clock.leave()

    threads = [threading.Thread(target=party, args=p) for p in plans]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert not any(t.is_alive() for t in threads)
    return seen, moved


def test_parties_wake_in_time_order_and_time_stands_still_while_one_works():
    clock = LockstepClock(START, parties=2)
    wall0 = time.monotonic()
    seen, moved = _run(clock, [("a", 1.0, 5), ("b", 1.5, 3)])
    assert not moved
    assert sorted(t for t, n in seen if n == "a") == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert sorted(t for t, n in seen if n == "b") == [1.5, 3.0, 4.5]
    assert clock.monotonic() == 5.0
    assert time.monotonic() - wall0 < 5.0         # no waiting for simulated time


def test_a_party_that_left_is_not_waited_for():
    clock = LockstepClock(START, parties=2)
    seen, _ = _run(clock, [("short", 1.0, 1), ("long", 10.0, 3)])
    assert sorted(t for t, n in seen if n == "long") == [10.0, 20.0, 30.0]


def test_a_party_blocked_outside_the_clock_does_not_hang_the_others():
    clock = LockstepClock(START, parties=2)
    clock.STALL_S = 0.05
    lock = threading.Lock()
    lock.acquire()                               # the other party waits on this for ever

    def blocked():
        with lock:
            pass
    other = threading.Thread(target=blocked, daemon=True)
    other.start()
    clock.sleep(3.0)                             # moves on after STALL_S of real time
    assert clock.monotonic() == 3.0
    lock.release()
    other.join(2)


def test_one_party_is_a_manual_clock():
    clock = LockstepClock(START)
    clock.sleep(2.5)
    assert clock.monotonic() == 2.5
