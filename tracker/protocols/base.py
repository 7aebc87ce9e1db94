"""The driver interface every rotator protocol implements.

A driver wraps an already-open, port-like object (anything with ``read``, ``write``,
``reset_input_buffer``, ``timeout``; see :func:`tracker.transport.open_port`). Positions are
*wire degrees*: what the controller reports and accepts in its current mode; turning
mechanical or true bearings into wire degrees is the caller's job (see docs/architecture.md).
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from types import TracebackType
from typing import Literal

from tracker.errors import TrackerError

Direction = Literal["cw", "ccw", "up", "down"]


@dataclass(frozen=True)
class Capabilities:
    """What a controller can do, so callers can choose a strategy without probing."""

    has_elevation: bool = True
    has_position_query: bool = True
    has_axis_stop: bool = True
    has_manual_move: bool = True
    has_speed: bool = True
    speed_steps: int = 4
    has_step_tables: bool = False
    max_table_points: int = 0        # M angles (az-only) per table
    max_table_pairs: int = 0         # W az/el pairs per table
    max_line_chars: int = 0          # longest command line the controller accepts (0 = none)
    table_period_extra_s: float = 0.0  # real step period is interval_s + this (K3NG: +1 s)
    has_450_mode: bool = False
    has_centre_toggle: bool = False
    az_max_deg: float = 450.0
    el_max_deg: float = 180.0


class RotatorDriver(abc.ABC):
    """One controller behind one port. Methods block until done and never hang: every read is
    bounded by the driver's timeout and raises :class:`tracker.errors.RotatorTimeout`."""

    capabilities: Capabilities

    @abc.abstractmethod
    def position(self) -> tuple[float, float | None]:
        """Current ``(az_deg, el_deg)`` as the controller reports them (``el`` None if az-only)."""

    @abc.abstractmethod
    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        """Start turning to ``az_deg`` (and ``el_deg``); returns without waiting for arrival."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Stop every axis now."""

    def stop_axis(self, axis: Literal["az", "el"]) -> None:
        """Stop one axis; controllers without per-axis stop stop everything."""
        self.stop()

    @abc.abstractmethod
    def close(self) -> None:
        """Release the port (does not send a stop: callers decide, see :meth:`__exit__`)."""

    def __enter__(self) -> RotatorDriver:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        # Every exit path sends all-stop unless the caller wants the move to go on (a
        # rotctl-like "goto and quit"); a lost port must not mask the original error.
        try:
            if getattr(self, "stop_on_exit", True):
                self.stop()
        except TrackerError:
            if exc_type is None:
                raise
        finally:
            self.close()
