"""The rolling schedule of station mode on the bundled element snapshot: choice by priority
with reasons for every skipped pass, stable keys, kept passes across a recompute, the stream
/ table decision, the Sun as a target, and one-line errors for unknown names."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from datetime import datetime, timezone

import pytest

from tle.catalog import Catalog
from tracker.config import ScheduleSettings
from tracker.controllers import controller
from tracker.errors import ConfigError, PropagationError
from tracker.mount import preset
from tracker.service.plan import build_rolling_schedule, pass_key, wanted_targets
from tracker.station import Station

START_S = datetime(2026, 8, 20, tzinfo=timezone.utc).timestamp()
STATION = Station(name="home", lat_deg=52.0, lon_deg=4.4)
SPEC = preset("G-5500")
NO_TABLES = controller("rotctld")
TABLES = controller("gs232b")


@pytest.fixture(scope="module")
def catalog():
    return Catalog.bundled_snapshot()


def settings(**kw) -> ScheduleSettings:
    base = dict(targets={"ISS (ZARYA)": 3, "SO-50": 1, "FO-29": 2}, horizon_h=12.0)
    base.update(kw)
    return ScheduleSettings(**base)


@pytest.fixture(scope="module")
def schedule(catalog):
    return build_rolling_schedule(catalog, STATION, SPEC, settings(), NO_TABLES, START_S)


def test_chosen_passes_do_not_overlap_and_skipped_say_why(schedule):
    chosen = schedule.chosen
    assert len(chosen) >= 5 and all(p.state == "planned" for p in chosen)
    assert [p.aos_s for p in chosen] == sorted(p.aos_s for p in chosen)
    for a, b in itertools.pairwise(chosen):
        assert a.los_s + 60.0 <= b.aos_s  # settle_s kept free (plus the slew)
    assert all(p.pass_.max_el_deg >= 10.0 and p.los_s > START_S for p in chosen)
    reasons = {p.reason.split(" (")[0].split(" ")[0] for p in schedule.skipped}
    assert reasons <= {"overlaps", "max"} and schedule.skipped
    for p in schedule.skipped:
        assert p.state == "skipped"
        if p.reason.startswith("max el"):
            assert p.pass_.max_el_deg < 10.0 and p.reason.endswith("< 10")
        else:  # lost to an overlapping chosen pass of at least its priority
            rival = next(c for c in chosen if p.reason == f"overlaps {c.target.name} "
                                                          f"(priority {c.priority})")
            assert rival.priority >= p.priority
            assert rival.aos_s < p.los_s + 600 and p.aos_s < rival.los_s + 600


def test_entries_and_due(schedule):
    entries = schedule.entries()
    assert len(entries) == len(schedule.chosen) + len(schedule.skipped)
    assert [e["aos_utc"] for e in entries] == sorted(e["aos_utc"] for e in entries)
    first = schedule.chosen[0]
    e = first.entry()
    assert set(e) == {"key", "target", "aos_utc", "los_utc", "max_el_deg", "priority", "mode",
                      "state", "reason"}
    assert e["key"] == first.key and e["target"] == first.target.name
    assert e["aos_utc"].endswith("Z") and e["mode"] == "stream"
    assert schedule.due(START_S) is first
    first.state = "done"
    try:
        assert schedule.due(START_S) is schedule.chosen[1]
        assert schedule.due(schedule.chosen[-1].los_s) is None
    finally:
        first.state = "planned"


def test_key_is_id_and_aos_rounded_to_10_s(schedule):
    p = next(p for p in schedule.chosen if p.target.name == "ISS (ZARYA)")
    assert p.key.startswith("25544-20260820T") and p.key.endswith("0Z")
    assert p.key == pass_key(p.target, p.aos_s)
    whole_s = datetime(2026, 8, 20, 4, 30, 30, tzinfo=timezone.utc).timestamp()
    assert {pass_key(p.target, whole_s + d) for d in (-4.9, 0.0, 4.9)} == {
        "25544-20260820T043030Z"}          # fresher elements move AOS by seconds: same key
    assert pass_key(p.target, whole_s + 5.1) == "25544-20260820T043040Z"


def test_a_recompute_keeps_done_and_tracking_passes(catalog, schedule):
    done, tracking = (replace(p) for p in schedule.chosen[:2])
    done.state, tracking.state = "done", "tracking"
    now_s = tracking.aos_s + 60.0           # a recompute during the pass being tracked
    # fresher priorities would now prefer everything else: kept passes stay all the same
    again = build_rolling_schedule(
        catalog, STATION, SPEC, settings(targets={"ISS (ZARYA)": 1, "SO-50": 5, "FO-29": 5}),
        NO_TABLES, now_s, keep=[done, tracking, *schedule.chosen[2:]])
    keys = [p.key for p in again.chosen]
    assert again.chosen[0] is done and again.chosen[1] is tracking
    assert (done.state, tracking.state) == ("done", "tracking")
    assert len(set(keys)) == len(keys)
    assert done.key not in {p.key for p in again.skipped}
    assert tracking.key not in {p.key for p in again.skipped}
    assert again.due(now_s) is not tracking and again.due(now_s).aos_s > tracking.los_s


def test_planned_passes_lend_their_mode_decision(catalog, schedule):
    marked = [replace(p, mode_reason="from before") for p in schedule.chosen]
    again = build_rolling_schedule(catalog, STATION, SPEC, settings(), NO_TABLES, START_S,
                                   keep=marked)
    assert [p.key for p in again.chosen] == [p.key for p in schedule.chosen]
    assert {p.mode_reason for p in again.chosen} == {"from before"}
    assert all(p.state == "planned" for p in again.chosen)


def test_auto_mode_on_a_controller_with_tables(catalog):
    s = build_rolling_schedule(catalog, STATION, SPEC, settings(targets={"SO-50": 1},
                                                                horizon_h=6.0),
                               TABLES, START_S)
    assert s.chosen
    for p in s.chosen:
        limit = SPEC.deadband_deg + 1.0
        assert math.isfinite(p.predicted_max_error_deg)
        if p.mode == "table":
            assert p.predicted_max_error_deg <= limit
            assert p.mode_reason.startswith("step table predicted max error")
        else:
            assert f"> {limit:.1f} deg" in p.mode_reason
    tight = replace(SPEC, deadband_deg=0.0)      # deadband 0: within 1 deg only
    s2 = build_rolling_schedule(catalog, STATION, tight, settings(targets={"SO-50": 1},
                                                                 horizon_h=6.0, mode="auto"),
                                TABLES, START_S)
    assert all((p.mode == "table") == (p.predicted_max_error_deg <= 1.0) for p in s2.chosen)


@pytest.mark.parametrize(("mode", "proto", "expect", "reason"), [
    ("table", "rotctld", "stream", "controller has no step tables"),
    ("auto", "rotctld", "stream", "controller has no step tables"),
    ("stream", "gs232b", "stream", "mode = stream"),
    ("table", "gs232b", "table", "mode = table"),
])
def test_forced_modes(catalog, mode, proto, expect, reason):
    s = build_rolling_schedule(catalog, STATION, SPEC,
                               settings(targets={"SO-50": 1}, horizon_h=4.0, mode=mode),
                               controller(proto), START_S)
    assert s.chosen
    assert {(p.mode, p.mode_reason) for p in s.chosen} == {(expect, reason)}


def test_the_sun_is_a_target(catalog):
    s = build_rolling_schedule(catalog, STATION, SPEC,
                               settings(targets={"Sun": 1}, horizon_h=24.0), NO_TABLES,
                               START_S)
    (sun,) = s.chosen
    assert sun.key.startswith("Sun-20260820T") and sun.target.name == "Sun"
    assert sun.pass_.max_el_deg > 40.0 and sun.mode == "stream"


def test_groups_and_priority_zero(catalog):
    wanted = wanted_targets(catalog, ScheduleSettings(groups={"weather": 1},
                                                      targets={"NOAA 20": 0, "METOP-B": 4}))
    names = {t.name: p for t, p in wanted}
    assert len(names) == len(catalog.group("weather")) - 1
    assert not any(n.startswith("NOAA 20") for n in names)
    assert names["METOP-B"] == 4 and set(names.values()) == {1, 4}


@pytest.mark.parametrize(("kw", "message"), [
    ({"targets": {"ISSS (ZARYA)": 1}},
     r"^\[schedule\] targets: no satellite 'ISSS \(ZARYA\)' .*did you mean 'ISS \(ZARYA\)'"),
    ({"groups": {"wether": 1}}, r"^\[schedule\] groups: no group 'wether' .*did you mean"),
])
def test_unknown_names_are_one_line(catalog, kw, message):
    with pytest.raises(ConfigError, match=message) as info:
        wanted_targets(catalog, ScheduleSettings(**kw))
    assert "\n" not in str(info.value)


def test_a_day_no_satellite_can_be_predicted_for_says_so(catalog):
    far_s = datetime(1900, 1, 1, tzinfo=timezone.utc).timestamp()
    with pytest.raises(PropagationError, match=r"days before the elements' epoch .* only "
                                               r"usable within 730 days"):
        build_rolling_schedule(catalog, STATION, SPEC, settings(), NO_TABLES, far_s)
    # one target with elements of that time is enough: the others are left out quietly
    sun = build_rolling_schedule(catalog, STATION, SPEC, settings(targets={"Sun": 1,
                                                                             "SO-50": 1}),
                                 NO_TABLES, far_s)
    assert {p.target.name for p in sun.chosen} == {"Sun"}
