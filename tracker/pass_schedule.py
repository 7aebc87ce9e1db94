"""One rotator, many passes: pick which to track when they overlap (``tracker schedule``).

Not to be confused with :mod:`tracker.pointing_file`, a user-given az/el pointing plan.

The choice is a weighted interval schedule: each pass weighs its satellite's priority (times
1000, plus its max elevation as the tie-break, so priority always wins and then the higher
pass). Two passes can both be tracked only if the rotator can slew from the first pass's LOS
direction to the second's AOS direction between the two (start delay + the slower axis at the
rotator's rates, using the mechanical frame so a 360 deg rotator goes the long way round its
stop). Dynamic programming over passes sorted by LOS gives the best total weight exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tle.textfile import read_text_file
from tracker.errors import ConfigError
from tracker.export import PassRecords
from tracker.geometry import slew_s
from tracker.mount import RotatorSpec


@dataclass(frozen=True)
class Schedule:
    """``chosen``: indices into the pass records, in time order; ``skipped``: index ->
    the index of the chosen pass it lost to (or -1 when it had priority 0)."""

    chosen: list[int]
    skipped: dict[int, int]
    total_priority: int


def parse_priorities(items: list[str], path: str | Path | None = None) -> dict[str, int]:
    """Priorities from ``NAME=N`` items and/or a file of ``NAME=N`` / ``NAME,N`` lines.

    Names match satellites case-insensitively; N is an integer >= 0 (0 = never track).
    """
    out: dict[str, int] = {}
    sources: list[tuple[str, str]] = []
    if path is not None:
        path = Path(path)
        text = read_text_file(path, "priorities file", ConfigError,
                              hint="a priorities file has NAME=N lines")
        for no, line in enumerate(text.splitlines(), 1):
            line = line.split("#", 1)[0].strip()
            if line:
                sources.append((f"{path}:{no}", line))
    sources += [(f"priority {item}", item) for item in items]
    for where, item in sources:
        sep = "=" if "=" in item else ","
        name, _, value = item.rpartition(sep)
        name = name.strip().strip('"')
        try:
            level = int(value.strip())
        except ValueError:
            level = -1
        if not name or level < 0:
            raise ConfigError(f"{where}: expected NAME=N with N a whole number >= 0 "
                              f"(e.g. 'ISS (ZARYA)=5'), got {item!r}")
        out[name.lower()] = level
    return out


def priority_of(name: str, priorities: dict[str, int], default: int) -> int:
    return priorities.get(name.strip().lower(), default)


def _rivals(chosen: list[int], usable: np.ndarray, aos: np.ndarray, los: np.ndarray,
            max_slew: float) -> dict[int, int]:
    """Each pass not chosen -> the first chosen pass it clashes with (-1: none, or unusable)."""
    skipped: dict[int, int] = {}
    chosen_set = set(chosen)
    for i in range(len(aos)):
        if i in chosen_set:
            continue
        if not usable[i]:
            skipped[i] = -1
            continue
        rivals = [c for c in chosen if aos[c] < los[i] + max_slew and los[c] + max_slew > aos[i]]
        skipped[i] = rivals[0] if rivals else -1
    return skipped


def build_schedule(records: list[dict], spec: RotatorSpec, priorities: dict[str, int],
                   default_priority: int = 1, settle_s: float = 0.0) -> Schedule:
    """Best set of non-conflicting passes for one rotator (pass records of one station, as
    :meth:`tracker.export.PassRecords.rows` gives them).

    ``settle_s`` is extra time to keep free between passes (e.g. for a step-table upload).
    Records get a ``priority`` key.
    """
    if len({r["station"] for r in records}) > 1:
        raise ConfigError("a schedule is for one rotator at one station; give one station")
    n = len(records)
    for r in records:
        r["priority"] = priority_of(r["target"], priorities, default_priority)
    if n == 0:
        return Schedule([], {}, 0)
    aos = np.array([r["aos_s"] for r in records])
    los = np.array([r["los_s"] for r in records])
    weight = np.array([r["priority"] * 1000.0 + r["max_el_deg"] for r in records])
    usable = np.array([r["priority"] > 0 for r in records])
    # An upper bound of any slew: the whole span (or 180 deg of elevation) plus the delay.
    max_slew = slew_s(spec, 0.0, 0.0, spec.az_span_deg, 180.0)
    order = np.argsort(los, kind="stable")
    los_sorted = los[order]
    best = np.zeros(n)
    parent = np.full(n, -1)
    prefix_best = np.zeros(n + 1)  # best total among the first k passes in LOS order
    prefix_arg = np.full(n + 1, -1)
    for k, j in enumerate(order.tolist()):
        if not usable[j]:
            best[j] = -np.inf
        else:
            # Passes ending long enough before this AOS are compatible whatever the slew.
            m = int(np.searchsorted(los_sorted[:k], aos[j] - max_slew - settle_s, "right"))
            value, arg = prefix_best[m], prefix_arg[m]
            hi = int(np.searchsorted(los_sorted[:k], aos[j], "right"))
            for i in order[m:hi].tolist():
                if not usable[i] or best[i] <= value:
                    continue
                # from the LOS to the AOS bearing, the closest mechanical positions
                slew = slew_s(spec, spec.frame.mech_candidates(records[i]["los_az_deg"]), None,
                              spec.frame.mech_candidates(records[j]["aos_az_deg"]), None)
                if los[i] + slew + settle_s <= aos[j]:
                    value, arg = best[i], i
            best[j] = weight[j] + value
            parent[j] = arg
        if best[j] > prefix_best[k]:
            prefix_best[k + 1], prefix_arg[k + 1] = best[j], j
        else:
            prefix_best[k + 1], prefix_arg[k + 1] = prefix_best[k], prefix_arg[k]
    chosen = []
    j = int(prefix_arg[n])
    while j >= 0:
        chosen.append(j)
        j = int(parent[j])
    chosen.sort(key=lambda i: aos[i])
    skipped = _rivals(chosen, usable, aos, los, max_slew)
    total = int(sum(records[i]["priority"] for i in chosen))
    return Schedule(chosen, skipped, total)


def schedule_passes(records: PassRecords, spec: RotatorSpec, priorities: dict[str, int],
                    default_priority: int = 1, settle_s: float = 0.0) -> Schedule:
    """:func:`build_schedule` on pass records, filling their ``priority``, ``chosen`` and
    ``conflicts_with`` fields (the target of the chosen pass a skipped one lost to)."""
    rows = records.rows()
    sched = build_schedule(rows, spec, priorities, default_priority, settle_s)
    chosen = set(sched.chosen)
    lost = [sched.skipped.get(i) for i in range(len(rows))]
    records.set("priority", (r["priority"] for r in rows))
    records.set("chosen", (i in chosen for i in range(len(rows))))
    records.set("conflicts_with", (rows[k]["target"] if k is not None and k >= 0 else None
                                   for k in lost))
    return sched
