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
"""

from __future__ import annotations

import copy
import threading
from collections import deque
from collections.abc import Iterable, Mapping
from typing import Any

from tracker.clock import Clock
from tracker.timescale import iso_utc

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


def _r(v: float | None, nd: int = 2) -> float | None:
    return None if v is None else round(float(v), nd)
