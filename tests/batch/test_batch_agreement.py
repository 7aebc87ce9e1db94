"""The batch finder against skyfield's ``find_events`` on real elements.

Contract: no pass missed whose max elevation is >= the minimum + 0.1 deg, and
AOS/TCA/LOS within 1 s. Elements: the bundled amateur group (epochs 2026-08-22) and 322
objects of CelesTrak's active catalogue of 2026-03-19 (every 60th object plus deep-space,
GEO and highly eccentric ones), copied into tests/data/batch_active_sample.txt.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from _paths import DATA, REPO
from sgp4.api import Satrec
from skyfield.api import EarthSatellite, load

from tracker.batch import find_passes_batch
from tracker.station import Station

BUNDLED = REPO / "tle" / "data"
TS = load.timescale(builtin=True)


def read_sets(path: Path) -> list[tuple[str, str, str]]:
    lines = [x.strip() for x in path.read_text().splitlines() if x.strip()]
    return [(lines[i], lines[i + 1], lines[i + 2]) for i in range(0, len(lines) - 2, 3)]


@dataclass
class SkyPass:
    sat: int
    aos_s: float
    los_s: float
    tca_s: float | None  # None when skyfield reports several culminations
    max_el_deg: float


def skyfield_passes(sets, station: Station, start, end, min_el_deg):
    """Complete rise..set passes from find_events, with the highest culmination."""
    topos = station.topos()
    out, sats = [], []
    t0, t1 = TS.from_datetime(start), TS.from_datetime(end)
    for i, (name, l1, l2) in enumerate(sets):
        sat = EarthSatellite(l1, l2, name, TS)
        sats.append(sat)
        t, events = sat.find_events(topos, t0, t1, altitude_degrees=min_el_deg)
        if len(t) == 0:
            continue
        secs = np.array([d.timestamp() for d in t.utc_datetime()])
        alt = (sat - topos).at(t).altaz()[0].degrees
        j = 0
        while j < len(events):
            if events[j] != 0:
                j += 1
                continue
            k = j + 1
            while k < len(events) and events[k] == 1:
                k += 1
            if k >= len(events):
                break
            culm = list(range(j + 1, k))
            best = max(culm, key=lambda c: alt[c]) if culm else None
            out.append(SkyPass(i, secs[j], secs[k],
                               secs[best] if len(culm) == 1 else None,
                               float(alt[best]) if best is not None else min_el_deg))
            j = k + 1
    return out, sats


def altitude_at(sat, station: Station, t_s) -> np.ndarray:
    # POSIX seconds from 2026-01-01 (no leap second since 2017, none in the test windows).
    ref_s = datetime(2026, 1, 1, tzinfo=timezone.utc).timestamp()
    t = TS.utc(2026, 1, 1, 0, 0, np.atleast_1d(np.asarray(t_s, dtype=float)) - ref_s)
    return (sat - station.topos()).at(t).altaz()[0].degrees


def skyfield_consistent(sat, station, p: SkyPass, min_el_deg) -> bool:
    """Does skyfield's own altitude stay above the threshold inside its reported pass?"""
    t = np.linspace(p.aos_s, p.los_s, 200)[1:-1]
    return bool(np.all(altitude_at(sat, station, t) > min_el_deg - 0.01))


def dense_check(sat, station, rows, start, end, min_el_deg, step_s=10.0):
    """Our passes against skyfield altitudes every ``step_s``: same rises and sets."""
    t = np.arange(start.timestamp(), end.timestamp(), step_s)
    up = altitude_at(sat, station, t) >= min_el_deg
    rises = t[1:][up[1:] & ~up[:-1]]
    sets = t[1:][~up[1:] & up[:-1]]
    ours_aos = np.sort(rows["aos_s"][~rows["aos_clipped"]])
    ours_los = np.sort(rows["los_s"][~rows["los_clipped"]])
    assert len(rises) == len(ours_aos) and len(sets) == len(ours_los), (rises, rows)
    assert np.all((ours_aos > rises - step_s) & (ours_aos <= rises))
    assert np.all((ours_los > sets - step_s) & (ours_los <= sets))


def check_agreement(sets, station, start, end, min_el_deg):
    satrecs = [Satrec.twoline2rv(a, b) for _, a, b in sets]
    table = find_passes_batch(satrecs, [n for n, _, _ in sets], [station], start, end,
                              min_el_deg=min_el_deg)
    mine = table.passes
    sky, sats = skyfield_passes(sets, station, start, end, min_el_deg)
    assert len(sky) > 50
    matched = np.zeros(len(mine), bool)
    dense = set()
    for p in sky:
        cand = np.flatnonzero((mine["sat"] == p.sat) & (np.abs(mine["aos_s"] - p.aos_s) < 60))
        if p.max_el_deg < min_el_deg + 0.1 and len(cand) == 0:
            continue  # a grazing pass below the contract's margin may be missed
        if len(cand) != 1 or abs(mine[cand[0]]["los_s"] - p.los_s) > 1.0:
            if not skyfield_consistent(sats[p.sat], station, p, min_el_deg):
                dense.add(p.sat)
                continue
        assert len(cand) == 1, f"{sets[p.sat][0]} pass at {p.aos_s} missed (max {p.max_el_deg})"
        row = mine[cand[0]]
        matched[cand[0]] = True
        assert abs(row["aos_s"] - p.aos_s) <= 1.0, (sets[p.sat][0], row, p)
        assert abs(row["los_s"] - p.los_s) <= 1.0, (sets[p.sat][0], row, p)
        assert row["max_el_deg"] >= p.max_el_deg - 1e-3
        if p.tca_s is not None and abs(row["tca_s"] - p.tca_s) > 1.0:
            # Very flat maxima (GEO, deep space): then our TCA must be at least as high a
            # point as skyfield's, by skyfield's own reckoning.
            ours = altitude_at(sats[p.sat], station, row["tca_s"])[0]
            assert ours >= p.max_el_deg - 1e-5, (sets[p.sat][0], row, p)
    # Where find_events contradicts skyfield's own altitudes (it can skip a set/rise pair on
    # highly eccentric orbits), check against dense skyfield altitude samples instead.
    # Passes of ours find_events did not report are checked the same way: nothing invented.
    complete = ~mine["aos_clipped"] & ~mine["los_clipped"]
    extra = complete & ~matched & (mine["max_el_deg"] >= min_el_deg + 0.1)
    dense |= set(mine["sat"][extra].tolist())
    assert len(dense) <= 5, [sets[i][0] for i in dense]
    for i in dense:
        dense_check(sats[i], station, mine[mine["sat"] == i], start, end, min_el_deg)
    # Our AOS/LOS lie on the threshold by skyfield's own altitude (spot check of 40).
    rows = mine[complete][:: max(1, complete.sum() // 40)]
    for row in rows:
        alt = altitude_at(sats[row["sat"]], station, [row["aos_s"], row["los_s"]])
        assert np.all(np.abs(alt - min_el_deg) < 0.01), (row, alt)
    return table


def test_amateur_group_agrees_with_skyfield_two_days():
    sets = read_sets(BUNDLED / "amateur.txt")
    start = datetime(2026, 8, 22, 13, 45, tzinfo=timezone.utc)
    table = check_agreement(sets, Station("Delft", 52.0, 4.37, 10.0), start,
                            start + timedelta(days=2), 0.0)
    assert len(table) > 1000


def test_amateur_group_agrees_at_ten_degrees_far_south():
    sets = read_sets(BUNDLED / "amateur.txt")
    start = datetime(2026, 8, 23, 0, 0, tzinfo=timezone.utc)
    check_agreement(sets, Station("Hobart", -42.9, 147.3, 50.0), start,
                    start + timedelta(days=1), 10.0)


@pytest.mark.parametrize("min_el_deg", [0.0, 5.0])
def test_active_catalogue_sample_with_deep_space_agrees(min_el_deg):
    sets = read_sets(DATA / "batch_active_sample.txt")
    deep = sum(float(l2[52:63]) < 6.4 for _, _, l2 in sets)
    assert deep >= 80  # GEO, GNSS, Molniya/GTO are in the sample
    start = datetime(2026, 3, 19, 4, 51, tzinfo=timezone.utc)
    table = check_agreement(sets, Station("Boulder", 40.0, -105.3, 1650.0), start,
                            start + timedelta(days=1), min_el_deg)
    # Always-up GEO objects come back as one pass clipped at both window edges.
    whole = table.passes["aos_clipped"] & table.passes["los_clipped"]
    assert whole.sum() >= 10
