"""Fresh elements for a station run, on their own schedule and never at the cost of the run.

:class:`ElementKeeper` asks the element store (:class:`tle.store.TleStore`) to update each
source every ``refresh_s``; the store's rules hold (one download per source per
:data:`tle.store.MIN_INTERVAL_S` at most, conditional requests, a failed or suspicious download
never replaces the cached copy). A failure is reported as an event, with how old the elements
in use are, and the run goes on with the cache (and the bundled snapshot under it).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from datetime import datetime
from typing import Any

from tle.catalog import Catalog
from tle.errors import TleError
from tle.store import SourceInfo, TleStore
from tracker.clock import Clock
from tracker.timescale import iso_utc


def _no_events(kind: str, **details: Any) -> None:
    pass


class ElementKeeper:
    """Keeps the element ``sources`` (group names or URLs) of ``store`` fresh.

    ``events(kind, text=...)`` hears of each download ("info") and each failure ("fault").
    """

    def __init__(self, store: TleStore, sources: Sequence[str], clock: Clock,
                 refresh_s: float, events: Callable[..., None] = _no_events):
        self.store = store
        self.sources = tuple(sources)
        self.clock = clock
        self.refresh_s = float(refresh_s)
        self.events = events
        self._last_attempt_s: float | None = None
        self._notes: dict[str, str] = {}  # source spec -> what the last refresh did

    def due(self) -> bool:
        """True when ``refresh_s`` has passed since the last attempt (or there was none)."""
        return (self._last_attempt_s is None
                or self.clock.timestamp() - self._last_attempt_s >= self.refresh_s)

    def refresh(self) -> bool:
        """Update every source; True if any of them changed. Never raises for a failed
        download or a bad source: each becomes a "fault" event and the cache stays in use."""
        self._last_attempt_s = self.clock.timestamp()
        changed = False
        for spec in self.sources:
            try:
                result = self.store.update_source(self.store.resolve(spec))
            except (TleError, OSError) as e:
                self._notes[spec] = "download failed; cached copy kept"
                self.events("fault", text=f"elements {spec}: {e}; {self._in_use(spec)}")
                continue
            self._notes[spec] = result.status
            if result.status == "updated":
                changed = True
                self.events("info", text=f"elements {spec}: {result.message}")
        return changed

    def catalog(self) -> Catalog:
        """What to schedule from: every cached source united with the bundled snapshot."""
        return Catalog.default(self.store,
                               on_warning=lambda text: self.events("info", text=text))

    def ages(self, now: datetime) -> list[dict[str, Any]]:
        """Per source, for ``StatusBoard.set_elements``: ``source``, ``count``, ``age_h``
        (median element epoch before ``now``), ``checked_utc`` (last good check), ``note``."""
        out = []
        for spec in self.sources:
            info = self._info(spec)
            if info is None:
                out.append({"source": spec, "count": 0, "age_h": None, "checked_utc": None,
                            "note": self._notes.get(spec, "not downloaded yet") +
                            "; the bundled snapshot is used"})
                continue
            store_now_s = self.store.clock.timestamp()
            shift_s = now.timestamp() - store_now_s
            age_h = (None if info.median_epoch_age_days is None else
                     round(info.median_epoch_age_days * 24.0 + shift_s / 3600.0, 1))
            checked = (None if info.checked_age_s is None else
                       iso_utc(store_now_s - info.checked_age_s))
            out.append({"source": spec, "count": max(info.count, 0), "age_h": age_h,
                        "checked_utc": checked, "note": self._notes.get(spec, "")})
        return out

    def _info(self, spec: str) -> SourceInfo | None:
        try:
            name = self.store.resolve(spec).name
            return next((i for i in self.store.list() if i.name == name), None)
        except TleError:
            return None

    def _in_use(self, spec: str) -> str:
        """How old the elements of ``spec`` in use are, in words."""
        info = self._info(spec)
        if info is None or info.median_epoch_age_days is None:
            return "no cached copy: using the bundled snapshot"
        checked = ("" if info.checked_age_s is None else
                   f", last checked {info.checked_age_s / 3600.0:.1f} h ago")
        return (f"using the cached elements, {info.median_epoch_age_days * 24.0:.1f} h old "
                f"(median epoch){checked}")
