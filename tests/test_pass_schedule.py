"""One-rotator schedule: priorities, overlaps, the slew between passes, optimality."""

from __future__ import annotations

import itertools
import random

import pytest

from tracker.errors import ConfigError
from tracker.geometry import slew_s
from tracker.mount import RotatorSpec, preset
from tracker.pass_schedule import build_schedule, parse_priorities

SPEC = RotatorSpec(name="test", az_span_deg=360, stop_bearing_deg=180, el_max_deg=90,
                   az_rate_deg_s=6.0, el_rate_deg_s=3.0, start_delay_s=1.0)


def bearing_slew_s(spec, from_bearing, from_el, to_bearing, to_el):
    """The schedule's slew between passes: the closest mechanical positions of two bearings."""
    return slew_s(spec, spec.frame.mech_candidates(from_bearing), from_el,
                  spec.frame.mech_candidates(to_bearing), to_el)


def rec(name, aos, los, aos_az=0.0, los_az=0.0, el=30.0, station="S"):
    return {"target": name, "station": station, "aos_s": float(aos), "los_s": float(los),
            "tca_s": (aos + los) / 2, "aos_az_deg": aos_az, "los_az_deg": los_az,
            "max_el_deg": el}


def compatible(a, b, spec=SPEC):
    first, second = (a, b) if a["los_s"] <= b["los_s"] else (b, a)
    return first["los_s"] + bearing_slew_s(spec, first["los_az_deg"], 0,
                                           second["aos_az_deg"], 0) <= second["aos_s"]


def test_slew_uses_the_mechanical_frame():
    # South stop: 170 -> 190 deg true is 340 deg the long way round the stop.
    assert bearing_slew_s(SPEC, 170, 0, 190, 0) == pytest.approx(1.0 + 340 / 6.0)
    assert bearing_slew_s(SPEC, 190, 0, 200, 0) == pytest.approx(1.0 + 10 / 6.0)
    g5500 = preset("G-5500")  # 450 deg: the overlap gives a short way
    assert bearing_slew_s(g5500, 350, 0, 10, 0) < bearing_slew_s(SPEC, 350, 0, 10, 0) + 60
    assert bearing_slew_s(SPEC, 0, 0, 0, 90) == pytest.approx(1.0 + 30.0)
    assert slew_s(SPEC, 10.0, None, 70.0, None) == pytest.approx(1.0 + 60 / 6.0)


def test_priority_wins_an_overlap():
    records = [rec("LOW", 0, 600), rec("HIGH", 300, 900), rec("LATER", 2000, 2500)]
    s = build_schedule(records, SPEC, {"high": 5})
    assert s.chosen == [1, 2]
    assert s.skipped == {0: 1}
    assert s.total_priority == 6
    assert records[1]["priority"] == 5 and records[0]["priority"] == 1


def test_slew_time_between_passes_is_respected():
    # LOS at 170 deg, next AOS at 190 deg 30 s later: the south-stop rotator needs ~58 s.
    records = [rec("A", 0, 600, los_az=170, el=50), rec("B", 630, 1200, aos_az=190, el=40)]
    s = build_schedule(records, SPEC, {})
    assert len(s.chosen) == 1 and s.chosen == [0]  # higher elevation breaks the tie
    records[1]["aos_s"] = 600 + 60
    assert build_schedule(records, SPEC, {}).chosen == [0, 1]
    # settle time blocks it again
    assert build_schedule(records, SPEC, {}, settle_s=10).chosen == [0]


def test_priority_zero_never_tracked():
    records = [rec("A", 0, 100), rec("B", 1000, 1100)]
    s = build_schedule(records, SPEC, {"a": 0}, default_priority=1)
    assert s.chosen == [1] and s.skipped == {0: -1}
    assert build_schedule(records, SPEC, {}, default_priority=0).chosen == []


def test_dynamic_programme_is_optimal_against_brute_force():
    rng = random.Random(7)
    for _ in range(60):
        n = rng.randint(1, 9)
        records = []
        for k in range(n):
            aos = rng.uniform(0, 4000)
            records.append(rec(f"S{k % 4}", aos, aos + rng.uniform(60, 900),
                               rng.uniform(0, 360), rng.uniform(0, 360), rng.uniform(0, 90)))
        prios = {f"s{k}": rng.randint(0, 3) for k in range(4)}
        s = build_schedule(records, SPEC, prios)
        weight = [r["priority"] * 1000 + r["max_el_deg"] for r in records]
        assert all(compatible(records[a], records[b])
                   for a, b in itertools.combinations(s.chosen, 2))
        best = 0.0
        for size in range(n + 1):
            for combo in itertools.combinations(range(n), size):
                if any(records[i]["priority"] == 0 for i in combo):
                    continue
                ordered = sorted(combo, key=lambda i: records[i]["los_s"])
                if all(compatible(records[a], records[b])
                       for a, b in itertools.pairwise(ordered)):
                    best = max(best, sum(weight[i] for i in combo))
        assert sum(weight[i] for i in s.chosen) == pytest.approx(best)


def test_parse_priorities(tmp_path):
    f = tmp_path / "prio.txt"
    f.write_text("# favourites\nISS (ZARYA)=5\nAO-73, 3\n")
    assert parse_priorities(["SO-50=2", "iss (zarya)=7"], f) == {
        "iss (zarya)": 7, "ao-73": 3, "so-50": 2}
    f.write_text("ISS=high\n")
    with pytest.raises(ConfigError, match=r"prio\.txt:1: expected NAME=N"):
        parse_priorities([], f)
    with pytest.raises(ConfigError, match=r"^priority X=-1: "):
        parse_priorities(["X=-1"])
    with pytest.raises(ConfigError, match="cannot read"):
        parse_priorities([], tmp_path / "missing.txt")


def test_one_station_only():
    with pytest.raises(ConfigError, match="one station"):
        build_schedule([rec("A", 0, 1, station="X"), rec("B", 5, 6, station="Y")], SPEC, {})
