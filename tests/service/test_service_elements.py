"""Station mode's element keeper against a fake CelesTrak on 127.0.0.1, on a ManualClock: the
store's download rules hold, and no failure ever reaches the station run."""

from __future__ import annotations

from datetime import datetime, timezone

import pytest
from _celestrak import TLE_DATA

from tle.store import TleStore
from tracker.clock import ManualClock
from tracker.service.elements import ElementKeeper

T0 = datetime(2026, 8, 23, 12, tzinfo=timezone.utc)


@pytest.fixture
def rig(tmp_path, celestrak):
    clock = ManualClock(T0)
    store = TleStore(cache_dir=tmp_path / "cache", clock=clock, base_url=celestrak.base_url,
                     timeout_s=5.0)
    events: list[tuple[str, str]] = []
    keeper = ElementKeeper(store, ["amateur"], clock, refresh_s=3600.0,
                           events=lambda kind, **d: events.append((kind, d["text"])))
    return keeper, clock, events


def test_first_refresh_downloads_then_the_two_hour_rule(rig, celestrak):
    keeper, clock, events = rig
    assert keeper.due()
    assert keeper.refresh() is True
    assert len(celestrak.requests) == 1 and events == [("info", "elements amateur: 5 element "
                                                                "sets")]
    assert not keeper.due()
    assert keeper.catalog().group_origins("amateur") == ("bundled", "cache")
    clock.advance(3600.0)                     # due again, but the store's 2 h rule holds
    assert keeper.due() and keeper.refresh() is False
    assert len(celestrak.requests) == 1
    (age,) = keeper.ages(clock.now())
    assert age["source"] == "amateur" and age["count"] == 5 and age["note"] == "fresh"
    assert age["checked_utc"] == "2026-08-23T12:00:00Z" and age["age_h"] > 0


def test_not_modified_keeps_the_cache_and_a_new_version_is_a_change(rig, celestrak):
    keeper, clock, events = rig
    keeper.refresh()
    clock.advance(2 * 3600.0 + 1)
    assert keeper.refresh() is False               # 304
    _group, headers = celestrak.requests[-1]
    assert headers["if-none-match"] == '"v1"'
    assert keeper.ages(clock.now())[0]["note"] == "not modified"
    clock.advance(2 * 3600.0 + 1)
    celestrak.body = (TLE_DATA / "amateur5.json").read_bytes()
    celestrak.etag = '"v2"'
    assert keeper.refresh() is True
    assert events[-1] == ("info", "elements amateur: 5 element sets")
    assert [p.name for p in keeper.store.paths()] == ["amateur.json"]


def test_a_server_that_is_gone_is_a_fault_naming_the_age(rig, celestrak):
    keeper, clock, events = rig
    keeper.refresh()
    cached = keeper.store.paths()[0].read_bytes()
    celestrak.close()                              # connection refused from now on
    clock.advance(3 * 3600.0)
    assert keeper.refresh() is False               # no exception
    kind, text = events[-1]
    assert kind == "fault" and "cannot connect" in text and "cached copy kept" in text
    assert "using the cached elements" in text and "h old" in text
    assert "last checked 3.0 h ago" in text
    assert keeper.store.paths()[0].read_bytes() == cached
    assert keeper.ages(clock.now())[0]["note"] == "download failed; cached copy kept"
    assert keeper.catalog().group_origins("amateur") == ("bundled", "cache")


def test_offline_from_the_start_falls_back_to_the_snapshot(tmp_path):
    clock = ManualClock(T0)
    store = TleStore(cache_dir=tmp_path / "cache", clock=clock,
                     base_url="http://127.0.0.1:9/gp.php", timeout_s=2.0)
    events: list[tuple[str, str]] = []
    keeper = ElementKeeper(store, ["weather", "bad group!"], clock, 7200.0,
                           events=lambda kind, **d: events.append((kind, d["text"])))
    assert keeper.refresh() is False
    assert [k for k, _t in events] == ["fault", "fault"]
    assert "no cached copy: using the bundled snapshot" in events[0][1]
    assert "neither a CelesTrak group name" in events[1][1]
    ages = keeper.ages(clock.now())
    assert [a["count"] for a in ages] == [0, 0]
    assert ages[0]["note"].endswith("the bundled snapshot is used")
    assert keeper.catalog().bundled
