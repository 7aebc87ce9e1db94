"""A controller session's safety: effective limits, the move guard, and all-stop on every exit.

Every command that can move a rotator (``tracker rotator``, ``tracker track``, ``tracker
upload``; a library user alike) runs its controller I/O inside a :class:`ControllerSession`:

- **Signals.** For the session's lifetime SIGINT, SIGTERM and SIGHUP (terminal closed, ssh
  dropped) take the Ctrl-C path: they raise :class:`Interrupted` (a ``KeyboardInterrupt``) in
  the main thread, wherever it is (waiting for AOS, stepping a table, parking, waiting for a
  reply), so the command's own ``finally`` blocks run. A signal the process was started with
  ignored (``nohup``, a background job) stays ignored. The old handlers come back on exit.
- **All-stop last.** On every way out that is not a normal end (a signal, any exception) the
  session sends all-stop as the last thing on the wire, and on a normal end too when the
  command asks for it (``stop_at_end``). While it does, further signals are held off, so a
  second Ctrl-C cannot cut the stop short. An all-stop that cannot reach the controller never
  replaces the error that ended the session.
- **Effective limits.** :class:`EffectiveLimits` is the rotator spec (azimuth span, stop
  bearing, elevation range, azimuth-only) narrowed by what the driver reports it accepts (its
  :class:`~tracker.protocols.base.Capabilities`: GS-232B in P36 mode, rotctld's ``\\dump_caps``
  limits, an azimuth-only controller), plus the station's horizon mask (the planner's own
  :func:`~tracker.geometry.boresight_horizon_ok`). :meth:`ControllerSession.check_move` refuses
  (:class:`~tracker.errors.LimitError`, one line) any position outside them.

Frames: the guard takes *wire degrees*, what the controller takes and reports (and what
``tracker rotator position`` prints): the mechanical angle from the CCW stop for most
controllers, a true bearing for one that maps a south-centred scale itself
(``controller_maps_south``); :class:`~tracker.mount.MountFrame` converts. See
:func:`driver_limits` for the scale drivers are opened with.
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType, TracebackType
from typing import TYPE_CHECKING, Any, Literal, TypeAlias

from tracker.errors import LimitError, RotatorIOError, TrackerError

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.mount import RotatorSpec
    from tracker.protocols.base import Capabilities
    from tracker.station import Station

# What signal.signal() returns and takes back: a handler, SIG_DFL/SIG_IGN, or None.
_Handler: TypeAlias = "Callable[[int, FrameType | None], Any] | int | signal.Handlers | None"

# The signals that end a session the way Ctrl-C does (SIGHUP does not exist on Windows).
STOP_SIGNALS: tuple[int, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


def route_stop_signals(handler: Callable[[int, FrameType | None], object],
                       signals: tuple[int, ...] = STOP_SIGNALS) -> Callable[[], None]:
    """Send each of ``signals`` to ``handler``; returns the function that puts the old back.

    A signal the process was started with ignored (``nohup``, a background job of a
    non-interactive shell) stays ignored: whoever started us asked for that. Off the main
    thread Python allows no handlers, so nothing is routed there."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    old: dict[int, _Handler] = {}
    for sig in signals:
        if signal.getsignal(sig) is signal.SIG_IGN:
            continue
        old[sig] = signal.signal(sig, handler)

    def restore() -> None:
        for sig, previous in old.items():
            signal.signal(sig, previous)
        old.clear()
    return restore


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived; ``signame`` says which (``SIGINT``, ``SIGTERM``, ``SIGHUP``)."""

    def __init__(self, signum: int):
        self.signum = int(signum)
        self.signame = signal.Signals(signum).name
        super().__init__(self.signame)


# Effective limits ---------------------------------------------------------------------------


def driver_limits(spec: RotatorSpec, has_elevation: bool | None = None) -> dict:
    """The limit keywords every driver is opened with for ``spec`` (``open_driver(url, proto,
    **driver_limits(spec))``): one place, so live tracking, table upload and manual moves
    agree on the controller's scale."""
    el = spec.has_elevation if has_elevation is None else bool(has_elevation)
    return {"has_elevation": el and spec.has_elevation,
            "az_max_deg": spec.frame.wire_az_max_deg,
            "el_max_deg": float(spec.el_max_deg or 90.0)}


@dataclass(frozen=True)
class EffectiveLimits:
    """Where the antenna may be sent: the rotator spec narrowed by the controller, and the mask.

    ``wire_az_max_deg``: top of the accepted wire azimuth. ``az_mech_max_deg``: top of the
    mechanical travel still allowed. ``el_range_deg``: (min, max) elevation, or None for an
    azimuth-only rotator or controller. ``narrowed_by`` says what narrowed the spec, for the
    messages.
    """

    spec: RotatorSpec
    station: Station | None
    wire_az_max_deg: float
    az_mech_max_deg: float
    el_range_deg: tuple[float, float] | None
    narrowed_by: tuple[str, ...] = ()

    @classmethod
    def of(cls, spec: RotatorSpec, station: Station | None = None,
           capabilities: Capabilities | None = None) -> EffectiveLimits:
        """The spec's limits narrowed by ``capabilities`` (what the driver accepts)."""
        wire_max = spec.frame.wire_az_max_deg
        notes: list[str] = []
        el_range = (float(spec.el_min_deg), float(spec.el_max_deg)) \
            if spec.el_max_deg is not None else None
        if capabilities is not None:
            if capabilities.az_max_deg < wire_max:
                wire_max = float(capabilities.az_max_deg)
                notes.append(f"the controller takes azimuth up to {wire_max:g}")
            if el_range is not None and not capabilities.has_elevation:
                el_range = None
                notes.append("the controller drives azimuth only")
            elif el_range is not None and capabilities.el_max_deg < el_range[1]:
                el_range = (el_range[0], float(capabilities.el_max_deg))
                notes.append(f"the controller takes elevation up to "
                             f"{capabilities.el_max_deg:g}")
        return cls(spec, station, wire_max, spec.frame.mech_max_deg(wire_max), el_range,
                   tuple(notes))

    @property
    def has_elevation(self) -> bool:
        return self.el_range_deg is not None

    @property
    def wire_az_top_deg(self) -> float:
        """The highest wire azimuth allowed: the scale's top for a controller that takes
        bearings, else (wire = mechanical) the top of the mechanical travel allowed."""
        return self.wire_az_max_deg if self.spec.frame.wire_takes_bearing \
            else self.az_mech_max_deg

    def rotator(self) -> RotatorSpec:
        """The spec narrowed to these limits, for planning inside them (a controller that
        takes elevation up to 90 only gets no flip or keyhole plan over the top; a 450 deg
        rotator on a controller in 360 deg mode plans no overlap). A scale that ends just short
        of 360 (0-359) is a full turn; anything the spec cannot express is left to the guard
        and the driver, which refuse such moves."""
        spec = self.spec
        changes: dict = {}
        if not spec.frame.wire_takes_bearing and \
                360.0 <= self.az_mech_max_deg < spec.az_span_deg:
            changes["az_span_deg"] = self.az_mech_max_deg
            changes["park_az_deg"] = min(spec.park_az_deg, self.az_mech_max_deg)
        if spec.has_elevation and self.el_range_deg is not None \
                and self.el_range_deg[1] < spec.el_top_deg:
            changes["el_max_deg"] = self.el_range_deg[1]
            changes["park_el_deg"] = min(spec.park_el_deg, self.el_range_deg[1])
        return spec.with_(**changes) if changes else spec

    def describe(self) -> str:
        """``az 0-450, el 0-90`` in wire degrees, and what narrowed the spec."""
        text = f"az 0-{self.wire_az_top_deg:g}"
        if self.el_range_deg is not None:
            text += f", el {self.el_range_deg[0]:g}-{self.el_range_deg[1]:g}"
        else:
            text += ", azimuth only"
        why = f"rotator {self.spec.name}" + "".join(f"; {n}" for n in self.narrowed_by)
        return f"{text} ({why})"

    def check_wire(self, az_deg: float, el_deg: float | None) -> None:
        """Refuse (LimitError, one line, nothing sent) a wire position outside the limits or
        with the boresight below the horizon mask."""
        from tracker.geometry import boresight_horizon_ok, boresight_look

        where = f"az {az_deg:g}" + ("" if el_deg is None else f" el {el_deg:g}")
        fix = f"allowed: {self.describe()}"
        if not math.isfinite(az_deg) or (el_deg is not None and not math.isfinite(el_deg)):
            raise LimitError(f"{where} is not a position; give finite degrees ({fix})")
        if not 0.0 <= az_deg <= self.wire_az_top_deg + 1e-9:
            raise LimitError(f"{where}: azimuth {az_deg:g} is outside the limits; {fix}")
        if el_deg is None:
            return
        if self.el_range_deg is None:
            raise LimitError(f"{where}: this rotator moves in azimuth only; give AZ alone "
                             f"({fix})")
        lo, hi = self.el_range_deg
        if not lo - 1e-9 <= el_deg <= hi + 1e-9:
            raise LimitError(f"{where}: elevation {el_deg:g} is outside the limits; {fix}")
        station = self.station
        if station is None:
            return
        m = float(self.spec.frame.mech_of_wire(az_deg))
        if not bool(boresight_horizon_ok(self.spec, station, m, el_deg)):
            look_b = float(boresight_look(self.spec, m, el_deg)[0])
            floor = float(station.horizon_at(look_b))
            raise LimitError(f"{where} points below the horizon mask of station "
                             f"{station.name} ({floor:g} deg at bearing {look_b:.0f}); "
                             f"choose a higher elevation")


# The session ---------------------------------------------------------------------------------


class ControllerSession:
    """Safety for one controller session (see the module docstring).

    ``all_stop`` sends all-stop and returns True, or False / raises if it did not reach the
    controller. ``stop_at_end``: send it on a normal end too (a tracking loop that already
    parked and stopped, or a rotctl-like ``goto`` that must go on, says False). ``limits``
    (optional) is what :meth:`check_move` enforces; ``ignore_limits`` turns that check off for
    maintenance (the caller warns). ``on_stop_failed`` hears about an all-stop that failed
    while another error was already ending the session. ``signals``: the signals that end
    it (a service that reloads its configuration on SIGHUP leaves SIGHUP out).
    """

    def __init__(self, all_stop: Callable[[], object], *, stop_at_end: bool = True,
                 limits: EffectiveLimits | None = None, ignore_limits: bool = False,
                 on_stop_failed: Callable[[str], None] | None = None,
                 signals: tuple[int, ...] = STOP_SIGNALS):
        self.all_stop = all_stop
        self.signals = signals
        self.stop_at_end = stop_at_end
        self.limits = limits
        self.ignore_limits = ignore_limits
        self.on_stop_failed = on_stop_failed or (lambda _why: None)
        self.stopped = False          # the session's all-stop reached the controller
        self.signal: str | None = None  # the signal that ended the session, if one did
        self._stopping = False
        self._restore_signals: Callable[[], None] = lambda: None

    # Moves -----------------------------------------------------------------------------------

    def check_move(self, az_deg: float, el_deg: float | None) -> None:
        """Refuse (LimitError) a wire position outside the effective limits or the mask."""
        if self.ignore_limits or self.limits is None:
            return
        self.limits.check_wire(az_deg, el_deg)

    # Signals and the last word ---------------------------------------------------------------

    def _on_signal(self, signum: int, _frame: FrameType | None) -> None:
        if self._stopping:
            return             # the all-stop is on its way: let it finish
        if self.signal is None:
            self.signal = signal.Signals(signum).name
        raise Interrupted(signum)

    def __enter__(self) -> ControllerSession:
        self._restore_signals = route_stop_signals(self._on_signal, self.signals)
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> Literal[False]:
        self._stopping = True
        try:
            if exc_type is not None or self.stop_at_end:
                self._last_stop(failing=exc_type is not None)
        finally:
            self._restore_signals()
        return False

    def _last_stop(self, failing: bool) -> None:
        try:
            reached = self.all_stop()
        except (TrackerError, OSError) as e:
            if not failing:
                raise
            self.on_stop_failed(str(e))
            return
        if reached is False:
            if not failing:
                raise RotatorIOError("all-stop did not reach the controller; check the "
                                     "rotator and stop it by hand")
            self.on_stop_failed("all-stop did not reach the controller")
            return
        self.stopped = True
