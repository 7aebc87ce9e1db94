"""The virtual tier's bench: an emulated controller behind ``emu://`` on a ManualClock.

The code under test and the emulator share that one clock: every wait (the loop's cycle, a
read timeout, a reconnect back-off) is a jump of the clock, so a scenario runs in CPU time and
its bounds on simulated time are exact. Use :func:`virtual_rig` (the test closes the rig) and
hand ``rig.url`` and ``rig.clock`` to the code under test; :func:`sampled_clock` when the test
must watch the antenna between the loop's requests.
"""

from __future__ import annotations

from datetime import datetime, timezone

from tracker.clock import ManualClock
from tracker.emulator.virtual import Bench


class VirtualRig:
    """``ctl`` (the controller), ``bench`` (its emu:// device), ``clock``, ``url``."""

    def __init__(self, ctl, faults=(), seed: int = 0):
        self.ctl = ctl
        self.clock = ctl.clock
        self.bench = Bench(ctl, faults=faults, seed=seed)
        self.url = self.bench.url

    @property
    def injector(self):
        return self.bench.injector

    def written(self) -> bytes:
        """Every byte the clients wrote, in order."""
        return self.bench.bytes_written()

    def last_line(self) -> bytes:
        return self.ctl.log[-1][1].strip()

    def close(self) -> None:
        self.bench.close()


class SampledClock(ManualClock):
    """A ManualClock that calls ``on_tick()`` every ``sample_s`` of the time it is advanced
    through, so a test can watch the emulated antenna between the loop's requests (what a
    sampler thread did on a SimClock, exactly and without a thread)."""

    def __init__(self, start: datetime, sample_s: float = 0.25):
        super().__init__(start)
        self.sample_s = float(sample_s)
        self.on_tick = None
        self._next_sample = self.timestamp()

    def advance(self, seconds: float) -> None:
        end = self.timestamp() + seconds
        while self.on_tick is not None and self._next_sample <= end:
            super().advance(max(0.0, self._next_sample - self.timestamp()))
            self._next_sample += self.sample_s
            self.on_tick()
        super().advance(end - self.timestamp())


def sampled_clock(start_s: float, sample_s: float = 0.25) -> SampledClock:
    return SampledClock(datetime.fromtimestamp(start_s, timezone.utc), sample_s)


def manual_clock(start_s: float) -> ManualClock:
    """A virtual clock at POSIX time ``start_s``."""
    return ManualClock(datetime.fromtimestamp(start_s, timezone.utc))


def virtual_rig(ctl, faults=(), seed: int = 0) -> VirtualRig:
    """Put ``ctl`` (built on a ManualClock) behind an emu:// URL; close the rig when done."""
    if not isinstance(ctl.clock, ManualClock):
        raise TypeError("a virtual rig needs its controller on a ManualClock")
    return VirtualRig(ctl, faults, seed)


def newest_bench(url: str) -> Bench:
    """The bench that the last ``emu://`` open of ``url`` made (a CLI run opens its own, on
    its own clock): earlier tests on the same worker may have left benches of the same URL."""
    from tracker.emulator import virtual

    return [b for name, b in virtual._BENCHES.items() if name.startswith(url + "#")][-1]
