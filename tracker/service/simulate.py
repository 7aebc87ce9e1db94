"""A station without hardware: the built-in emulator behind the service, for ``tracker
station run --simulate``, the tests and ``benchmarks/station.py``.

:func:`connector` is the one way the service opens a controller (real or emulated);
:func:`emulated` puts the protocol's emulator on an in-process bench (``emu://bench-N``) on
the run's clock, with an optional fault plan (:mod:`tracker.emulator.faults`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from functools import partial
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.clock import Clock
    from tracker.config import ScheduleSettings
    from tracker.controllers import Controller
    from tracker.emulator.virtual import Bench
    from tracker.mount import RotatorSpec

# A simulated day from a fresh install, without a config: a few satellites of the bundled
# snapshot, the ISS first.
SIMULATION_TARGETS = {"ISS (ZARYA)": 3, "NOAA 20": 2, "METEOR-M2 3": 2, "SO-50": 1,
                      "AO-7": 1, "FUNCUBE-1": 1, "IO-117": 1}


def simulation_schedule() -> ScheduleSettings:
    """The schedule a simulation runs when the config has none."""
    from tracker.config import ScheduleSettings

    return ScheduleSettings(targets=dict(SIMULATION_TARGETS), groups={})


def connector(url: str, entry: Controller, spec: RotatorSpec, clock: Clock,
              baudrate: int | None = None) -> Callable[[], Any]:
    """What opens the controller's driver for ``spec`` on ``url``: the limits' scale, the
    run's clock, and the motor model of an open-loop controller."""
    from tracker.protocols import open_driver
    from tracker.session import driver_limits

    kw: dict[str, Any] = driver_limits(spec)
    if baudrate:
        kw["baudrate"] = baudrate
    if entry.open_loop:
        kw["spec"] = spec
    return partial(open_driver, url, entry.name, clock=clock, **kw)


def emulated(entry: Controller, spec: RotatorSpec, clock: Clock, *,
             faults: Iterable[str] = (), seed: int = 0) -> tuple[Bench, Callable[[], Any]]:
    """The protocol's emulator with ``spec`` behind it on an in-process bench, and the
    connect callable that opens it."""
    from tracker.emulator.factory import make_emulator
    from tracker.emulator.virtual import Bench

    bench = Bench(make_emulator(entry.name, clock, spec), faults=tuple(faults), seed=seed)
    return bench, connector(bench.url, entry, spec, clock)
