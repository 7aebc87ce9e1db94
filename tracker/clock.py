"""Clocks: the only place the project reads the time of day or sleeps (apart from the
real-time default of ``tle.store``, which cannot import ``tracker``).

Library code takes a :class:`Clock` and never calls ``time.time()`` or
``datetime.now()``. :class:`SystemClock` is real time; :class:`SimClock` runs a simulated
UTC timeline ``speed`` times faster than the wall clock (demos, emulators, end-to-end tests,
shared by threads); :class:`ManualClock` only moves when told or when someone sleeps on it
(single-threaded unit tests); :class:`LockstepClock` is that shared by threads (virtual time)
and :class:`PacedClock` virtual time held to a watchable pace.
"""

from __future__ import annotations

import math
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


class LockstepClock(ManualClock):
    """A ManualClock shared by ``parties`` threads (virtual time for concurrent loops).

    Time moves only when every party still running is asleep on the clock, and then to the
    earliest wake-up: the threads interleave as they would on a real clock, but in CPU time
    and the same way every run. A party that ends calls :meth:`leave`. A sleeper that waits
    :attr:`STALL_S` of real time for a party that is neither running to its next sleep nor
    gone (blocked outside the clock, e.g. on a lock another sleeper holds) moves time on
    anyway: never a hang. A thread that is not a party (parties counted out) just advances.
    """

    STALL_S = 10.0

    def __init__(self, start: datetime, parties: int = 1):
        super().__init__(start)
        self._cv = threading.Condition()
        self._parties = int(parties)
        self._wakes: dict[int, float] = {}        # thread ident -> wake-up (POSIX s)

    def sleep(self, seconds: float) -> None:
        if seconds <= 0:
            return
        me = threading.get_ident()
        with self._cv:
            wake = self.timestamp() + seconds
            self._wakes[me] = wake
            self._cv.notify_all()
            try:
                while self.timestamp() < wake:
                    # every party asleep and none already due (a due one has yet to leave)
                    if len(self._wakes) >= self._parties and \
                            min(self._wakes.values()) > self.timestamp():
                        self._step()
                    elif not self._cv.wait(timeout=self.STALL_S):
                        self._step()
            finally:
                del self._wakes[me]
                self._cv.notify_all()

    def _step(self) -> None:
        """Move time to the earliest wake-up of the sleepers (caller holds the condition)."""
        t = min(self._wakes.values())
        with self._lock:
            self._ts = max(self._ts, t)
        self._cv.notify_all()

    def leave(self) -> None:
        """The calling party is done: the others no longer wait for it."""
        with self._cv:
            self._parties -= 1
            self._cv.notify_all()


class PacedClock(LockstepClock):
    """Virtual time that a person can watch: a :class:`LockstepClock` (every wait a jump of
    the clock, the same way every run) whose jumps are held back until ``1/speed`` real
    seconds per simulated second have passed since the start. Falling behind (the loop's
    own work) is caught up, never made up for by a faster pace later."""

    def __init__(self, start: datetime, speed: float, parties: int = 1):
        if not (math.isfinite(speed) and speed > 0):
            raise ValueError(f"speed {speed} must be a finite number above 0")
        super().__init__(start, parties)
        self.speed = float(speed)
        self._sim0_s = self.timestamp()
        self._real0_s = time.monotonic()

    def _step(self) -> None:
        due_real_s = self._real0_s + (min(self._wakes.values()) - self._sim0_s) / self.speed
        wait_s = due_real_s - time.monotonic()
        if wait_s > 0:
            time.sleep(wait_s)
        super()._step()


def utc(year: int, month: int, day: int, hour: int = 0, minute: int = 0, second: float = 0.0
        ) -> datetime:
    """A timezone-aware UTC datetime; fractional seconds allowed."""
    whole = int(second)
    return datetime(year, month, day, hour, minute, whole, tzinfo=timezone.utc) + timedelta(
        seconds=second - whole)
