"""What a running station shows: one thread-safe board the service writes and readers copy.

The station loop (:mod:`tracker.service.runner`) writes; the status page and its JSON API
(:mod:`tracker.service.web`) and the control port read. Every reader gets a deep copy made
under the lock, ready for ``json.dumps``: no reader can see half an update or hold the lock.

The shapes are the JSON API's (``docs/station.md``):

``status()``::

    {"station": {"name", "lat_deg", "lon_deg", "alt_m"},
     "rotator": {"name", "protocol", "port", "az_min_deg", "az_max_deg", "el_max_deg"},
     "simulated": bool, "now_utc": "...Z", "started_utc": "...Z",
     "state": "idle" | "prepositioning" | "tracking" | "uploading" | "parking" |
              "handed_over" | "fault" | "stopped",
     "detail": "one line: what it does and why",
     "antenna": {"az_deg", "el_deg", "utc"} | None,      # bearing (0-360), as read back
     "target": {"name", "az_deg", "el_deg", "error_deg"} | None,
     "current_pass": {"key", "target", "aos_utc", "los_utc", "max_el_deg", "mode",
                      "path": [[az_deg, el_deg], ...]} | None,
     "next_pass": the first schedule entry still "planned" | None,
     "control_port": {"listen", "owner": "station" | "outside", "clients"} | None,
     "elements": [{"source", "count", "age_h", "checked_utc", "note"}],
     "faults": [{"utc", "text"}] (newest last, at most FAULTS_KEPT),
     "counts": {"scheduled", "tracked", "skipped", "failed"}}

``schedule()``: the rolling schedule, AOS order, each
``{"key", "target", "aos_utc", "los_utc", "max_el_deg", "priority", "mode", "state",
"reason"}``, ``state`` one of ``planned``, ``tracking``, ``done``, ``skipped``, ``failed``.

``passes()``: the last PASSES_KEPT pass records, newest last, as the JSON-lines pass log
writes them (``key``, ``target``, ``aos_utc``, ``los_utc``, ``mode``, ``outcome``,
``reason``, ``predicted_max_error_deg``, ``measured_max_error_deg``, ``commands``,
``starts``, ``faults``).

:class:`BoardFeed` writes the live loop's output (:class:`tracker.stream.Status` records and
its events) onto a board, as one more sink of a :class:`tracker.trackui.Fanout`.
"""

from __future__ import annotations

import copy
import threading
from collections import deque
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

from tracker.clock import Clock
from tracker.timescale import iso_utc
from tracker.trackui import PHASE_WORDS, describe_state

if TYPE_CHECKING:
    from tracker.mount import RotatorSpec
    from tracker.stream import Status

FAULTS_KEPT = 50
PASSES_KEPT = 50
STATES = ("idle", "prepositioning", "tracking", "uploading", "parking", "handed_over",
          "fault", "stopped")


class StatusBoard:
    """The station's current state, schedule and history, shared between threads.

    ``clock`` stamps updates (the simulated one in a simulation). Writers call the ``set_*``
    and ``add_*`` methods; readers call :meth:`status`, :meth:`schedule` and :meth:`passes`.
    :attr:`version` grows with every write, so a reader can tell that something changed.
    """

    def __init__(self, clock: Clock, *, station: Mapping[str, Any] | None = None,
                 rotator: Mapping[str, Any] | None = None, simulated: bool = False):
        self._clock = clock
        self._lock = threading.Lock()
        self.version = 0
        self._status: dict[str, Any] = {
            "station": dict(station or {}), "rotator": dict(rotator or {}),
            "simulated": simulated, "now_utc": None, "started_utc": iso_utc(clock.now()),
            "state": "idle", "detail": "starting", "antenna": None, "target": None,
            "current_pass": None, "next_pass": None, "control_port": None, "elements": [],
            "faults": [], "counts": {"scheduled": 0, "tracked": 0, "skipped": 0, "failed": 0}}
        self._schedule: list[dict[str, Any]] = []
        self._faults: deque[dict[str, str]] = deque(maxlen=FAULTS_KEPT)
        self._passes: deque[dict[str, Any]] = deque(maxlen=PASSES_KEPT)

    # -- writers ---------------------------------------------------------------------------
    def _changed(self) -> None:
        self.version += 1

    def set_state(self, state: str, detail: str = "") -> None:
        if state not in STATES:
            raise ValueError(f"unknown station state {state!r}; one of {', '.join(STATES)}")
        with self._lock:
            self._status["state"], self._status["detail"] = state, detail
            self._changed()

    def set_antenna(self, az_deg: float | None, el_deg: float | None) -> None:
        """The antenna as last read back (bearing, 0-360), or None if unknown."""
        with self._lock:
            self._status["antenna"] = (None if az_deg is None else
                                       {"az_deg": round(float(az_deg), 2),
                                        "el_deg": None if el_deg is None
                                        else round(float(el_deg), 2),
                                        "utc": iso_utc(self._clock.now())})
            self._changed()

    def set_target(self, name: str | None, az_deg: float | None = None,
                   el_deg: float | None = None, error_deg: float | None = None) -> None:
        with self._lock:
            self._status["target"] = (None if name is None else
                                      {"name": name, "az_deg": _r(az_deg), "el_deg": _r(el_deg),
                                       "error_deg": _r(error_deg)})
            self._changed()

    def set_current_pass(self, entry: Mapping[str, Any] | None) -> None:
        with self._lock:
            self._status["current_pass"] = None if entry is None else dict(entry)
            self._changed()

    def set_schedule(self, entries: Iterable[Mapping[str, Any]]) -> None:
        with self._lock:
            self._schedule = [dict(e) for e in entries]
            self._recount()
            self._changed()

    def update_pass(self, key: str, **fields: Any) -> None:
        """Change one schedule entry (its ``state``, ``reason`` ...)."""
        with self._lock:
            for e in self._schedule:
                if e.get("key") == key:
                    e.update(fields)
            self._recount()
            self._changed()

    def set_elements(self, sources: Iterable[Mapping[str, Any]]) -> None:
        with self._lock:
            self._status["elements"] = [dict(s) for s in sources]
            self._changed()

    def set_control_port(self, info: Mapping[str, Any] | None) -> None:
        with self._lock:
            self._status["control_port"] = None if info is None else dict(info)
            self._changed()

    def add_fault(self, text: str) -> None:
        with self._lock:
            self._faults.append({"utc": iso_utc(self._clock.now()), "text": text})
            self._changed()

    def add_pass(self, record: Mapping[str, Any]) -> None:
        with self._lock:
            self._passes.append(dict(record))
            self._changed()

    def _recount(self) -> None:
        states = [e.get("state") for e in self._schedule]
        self._status["counts"] = {
            "scheduled": len(states), "tracked": states.count("done"),
            "skipped": states.count("skipped"), "failed": states.count("failed")}

    # -- readers ---------------------------------------------------------------------------
    def current_target(self) -> str | None:
        """The current pass's target name, if a pass is current (no copy of the board)."""
        with self._lock:
            cur = self._status["current_pass"]
            return None if not cur or cur.get("target") is None else str(cur["target"])

    def status(self) -> dict[str, Any]:
        with self._lock:
            out = copy.deepcopy(self._status)
            out["faults"] = list(self._faults)
            out["next_pass"] = next((dict(e) for e in self._schedule
                                     if e.get("state") == "planned"), None)
        out["now_utc"] = iso_utc(self._clock.now())
        return out

    def schedule(self) -> list[dict[str, Any]]:
        with self._lock:
            return copy.deepcopy(self._schedule)

    def passes(self) -> list[dict[str, Any]]:
        with self._lock:
            return copy.deepcopy(list(self._passes))


# The loop's phases as station states (``done``: the pass is over, the station waits again).
PHASE_STATES = {"wait": "idle", "preposition": "prepositioning", "track": "tracking",
                "park": "parking", "done": "idle"}
# Loop states that are faults: logged on the board. Those in FAULT_STATES also put the
# station in "fault" until the next phase change or a reconnect: the loop gave up on the
# pass, cannot reach the port, or could not stop the antenna. A read-back that disagrees or
# a controller without a position is only logged: the loop sends no event when it clears.
# ``no_reply`` is left out: one missed reply is routine, a silent port becomes ``port_lost``.
FAULT_EVENTS = ("stall", "port_lost", "reconnect_failed", "stop_failed",
                "readback_inconsistent", "contradiction", "controller_off")
FAULT_STATES = ("stall", "port_lost", "readback_inconsistent", "stop_failed")


class BoardFeed:
    """The live loop's output onto a :class:`StatusBoard`: a sink with the ``status`` /
    ``event`` / ``close`` of the loop's other outputs, to sit in a
    :class:`tracker.trackui.Fanout` beside them.

    :meth:`status` sets the antenna (as a bearing, 0-360) and the target (its name:
    ``target``, else the board's current pass). :meth:`event` turns phase changes into the
    station's state and the loop's fault states into board faults (:data:`FAULT_EVENTS`).
    ``spec``: the rotator, for antennas without an elevation axis and a read-back that has a
    mechanical azimuth but no bearing.
    """

    def __init__(self, board: StatusBoard, spec: RotatorSpec | None = None, *,
                 target: str | None = None):
        self.board = board
        self.spec = spec
        self.target = target
        self._phase_state = "idle"
        self._phase_detail = ""

    def _target_name(self) -> str:
        return self.target or self.board.current_target() or "target"

    def status(self, st: Status) -> None:
        bearing = st.antenna_bearing_deg
        if bearing is None and st.antenna_az_m_deg is not None and self.spec is not None:
            bearing = float(self.spec.bearing_of(st.antenna_az_m_deg))
        self.position(bearing, st.antenna_el_deg, st.target_az_deg, st.target_el_deg,
                      st.error_deg)

    def position(self, bearing_deg: float | None, el_deg: float | None,
                 target_az_deg: float, target_el_deg: float,
                 error_deg: float | None) -> None:
        """The antenna as read back (a bearing) and the target, from a live loop's cycle or
        a step table's read-back."""
        if self.spec is not None and not self.spec.has_elevation:
            el_deg = None
        self.board.set_antenna(None if bearing_deg is None else bearing_deg % 360.0, el_deg)
        self.board.set_target(self._target_name(), target_az_deg % 360.0, target_el_deg,
                              error_deg)

    def event(self, kind: str, **data: Any) -> None:
        if kind == "state":
            self._state(data)

    def _state(self, data: dict[str, Any]) -> None:
        state = str(data.get("state"))
        if state == "phase":
            phase = str(data.get("phase"))
            self._phase_state = PHASE_STATES.get(phase, "idle")
            words = PHASE_WORDS.get(phase, phase)
            self._phase_detail = words if phase in ("wait", "done") else \
                f"{words}: {self._target_name()}"
            self.board.set_state(self._phase_state, self._phase_detail)
        elif state == "reconnected":
            self.board.set_state(self._phase_state, describe_state(data) or state)
        elif state in FAULT_EVENTS:
            text = describe_state(data) or state
            self.board.add_fault(text)
            if state in FAULT_STATES:
                self.board.set_state("fault", text)

    def close(self) -> None:
        return None


def _r(v: float | None, nd: int = 2) -> float | None:
    return None if v is None else round(float(v), nd)
