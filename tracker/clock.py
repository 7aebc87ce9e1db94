"""Clocks: the only place the project reads the time of day or sleeps.

Library code takes a :class:`Clock` and never calls ``time.time()`` or
``datetime.now()``. :class:`SystemClock` is real time; :class:`SimClock` runs a simulated
UTC timeline ``speed`` times faster than the wall clock (demos, emulators, end-to-end tests,
shared by threads); :class:`ManualClock` only moves when told or when someone sleeps on it
(single-threaded unit tests).
"""

from __future__ import annotations

import threading
import time
from datetime import datetime, timedelta, timezone
from typing import Protocol, runtime_checkable


def _require_aware(t: datetime) -> datetime:
    if t.tzinfo is None:
        raise ValueError("clock times must be timezone-aware (UTC); got a naive datetime")
    return t.astimezone(timezone.utc)


@runtime_checkable
class Clock(Protocol):
    """What every timed component needs."""

    speed: float

    def now(self) -> datetime:
        """Current UTC time (timezone-aware)."""

    def timestamp(self) -> float:
        """Current UTC time as POSIX seconds."""

    def monotonic(self) -> float:
        """Seconds on a monotonic scale of this clock (simulated seconds for SimClock)."""

    def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of this clock's time."""


class SystemClock:
    """Real time."""

    speed = 1.0

    def now(self) -> datetime:
        return datetime.now(timezone.utc)

    def timestamp(self) -> float:
        return time.time()

    def monotonic(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class SimClock:
    """Simulated UTC that starts at ``start`` and runs ``speed`` times faster than real time.

    Thread-safe and shared: an emulator thread and a tracking loop that use the same SimClock
    see the same simulated time, so a pass of ten minutes can be replayed in thirty seconds
    with the emulator's motor lag scaled consistently. The owner of a private simulation (the
    embedded demo, whose emulator runs on this very clock) may also :meth:`pause` it while it
    plans and :meth:`skip` idle stretches; simulated time never runs backwards.
    """

    def __init__(self, start: datetime, speed: float = 1.0):
        if speed <= 0:
            raise ValueError(f"SimClock speed must be > 0, got {speed}")
        self.speed = float(speed)
        self._start_ts = _require_aware(start).timestamp()
        self._lock = threading.Lock()
        self._real0 = time.monotonic()
        self._paused_at: float | None = None
        self._paused_total_s = 0.0
        self._skipped_s = 0.0

    def _real_elapsed_s(self) -> float:
        with self._lock:
            now = self._paused_at if self._paused_at is not None else time.monotonic()
            return now - self._real0 - self._paused_total_s

    def pause(self) -> None:
        """Freeze simulated time (e.g. while a slow pass search runs at a high speed)."""
        with self._lock:
            if self._paused_at is None:
                self._paused_at = time.monotonic()

    def resume(self) -> None:
        with self._lock:
            if self._paused_at is not None:
                self._paused_total_s += time.monotonic() - self._paused_at
                self._paused_at = None

    def skip(self, seconds: float) -> None:
        """Jump simulated time forward by ``seconds`` (ignored when negative)."""
        with self._lock:
            self._skipped_s += max(0.0, seconds)

    def monotonic(self) -> float:
        return self._real_elapsed_s() * self.speed + self._skipped_s

    def timestamp(self) -> float:
        return self._start_ts + self.monotonic()

    def now(self) -> datetime:
        return datetime.fromtimestamp(self.timestamp(), timezone.utc)

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds / self.speed)


class ManualClock:
    """A clock that moves only through :meth:`advance` or :meth:`sleep` (which returns at once)."""

    speed = float("inf")

    def __init__(self, start: datetime):
        self._ts = _require_aware(start).timestamp()
        self._t0 = self._ts
        self._lock = threading.Lock()

    def advance(self, seconds: float) -> None:
        with self._lock:
            self._ts += seconds

    def monotonic(self) -> float:
        return self._ts - self._t0

    def timestamp(self) -> float:
        return self._ts

    def now(self) -> datetime:
        return datetime.fromtimestamp(self._ts, timezone.utc)

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self.advance(seconds)


def utc(year: int, month: int, day: int, hour: int = 0, minute: int = 0, second: float = 0.0
        ) -> datetime:
    """A timezone-aware UTC datetime; fractional seconds allowed."""
    whole = int(second)
    return datetime(year, month, day, hour, minute, whole, tzinfo=timezone.utc) + timedelta(
        seconds=second - whole)
