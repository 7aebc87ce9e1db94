"""What the three events of a pass are called, by target kind.

Satellites have AOS/TCA/LOS; the Sun, Moon, planets and radio sources rise, transit and set.
A module of its own because targets of every kind (:mod:`tracker.targets`,
:mod:`tracker.celestial`) and the commands that print passes all need the names.
"""

from __future__ import annotations

EVENT_LABELS: dict[str, tuple[str, str, str]] = {
    "satellite": ("AOS", "TCA", "LOS"),
    "schedule": ("start", "max el", "end"),
}


def event_labels(kind: str) -> tuple[str, str, str]:
    """Labels for the start, highest point and end of a pass of a target of ``kind``."""
    return EVENT_LABELS.get(kind, ("rise", "transit", "set"))
