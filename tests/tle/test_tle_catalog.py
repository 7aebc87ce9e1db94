"""Catalogue lookups, groups, duplicates and element age on the bundled snapshot."""

from __future__ import annotations

import re
from datetime import datetime, timedelta, timezone
from pathlib import Path

import pytest
from _paths import DATA

from tle.catalog import Catalog, age_warning, age_warnings
from tle.checksum import compute_checksum
from tle.errors import AmbiguousSatelliteError, TleFormatError, TleWarning, UnknownSatelliteError
from tle.store import TleStore
from tracker.clock import ManualClock

TLE_DATA = DATA / "tle"
T0 = datetime(2026, 8, 23, tzinfo=timezone.utc)


@pytest.fixture(scope="module")
def bundled():
    return Catalog.bundled_snapshot()


@pytest.mark.parametrize("query", ["25544", "ISS (ZARYA)", "iss (zarya)", "ISS", "zarya",
                                   "1998-067A", "98067A", " 25544 "])
def test_find_iss_every_way(bundled, query):
    assert bundled.find(query).norad_id == 25544


@pytest.mark.parametrize(("query", "norad_id"), [
    ("AO-7", 7530),            # the part in parentheses; not AO-73 by substring
    ("AO-73", 39444),
    ("funcube-1", 39444),      # the part before the parentheses
    ("SAUDISAT 1C", 27607),
    ("7530", 7530),
])
def test_name_parts_and_ids(bundled, query, norad_id):
    assert bundled.find(query).norad_id == norad_id


def test_ambiguous_lists_candidates(bundled):
    with pytest.raises(AmbiguousSatelliteError, match=re.escape(
            "'NOAA' matches 2 satellites by partial name: NOAA 20 (JPSS-1) (43013), "
            "NOAA 21 (JPSS-2) (54234); give the full name or the NORAD id")) as info:
        bundled.find("NOAA")
    assert info.value.candidates == ("NOAA 20 (JPSS-1)", "NOAA 21 (JPSS-2)")


def test_unknown_suggests(bundled):
    with pytest.raises(UnknownSatelliteError, match=re.escape(
            "no satellite 'ISSS' in the bundled snapshot (343 sets); did you mean "
            "'ISS (ZARYA)'")) as info:
        bundled.find("ISSS")
    assert info.value.suggestions[0] == "ISS (ZARYA)"
    with pytest.raises(UnknownSatelliteError, match="tracker tle update") as info:
        bundled.find("qqqqqqqq")
    assert info.value.suggestions == ()
    with pytest.raises(UnknownSatelliteError, match="empty satellite name"):
        bundled.find("  ")


def test_groups_keep_shared_members(bundled):
    assert bundled.groups == ["amateur", "stations", "visual", "weather"]
    amateur = bundled.group("amateur")
    assert len(amateur) == 96 and 25544 in amateur  # ISS is in amateur and stations
    assert 25544 in bundled.group("stations")
    assert amateur.find("ISS").norad_id == 25544
    with pytest.raises(UnknownSatelliteError, match=re.escape(
            "no group 'amatuer' in the catalogue (groups: amateur, stations, visual, weather); "
            "did you mean amateur?")):
        bundled.group("amatuer")


def test_search_and_iteration(bundled):
    hits = bundled.search("noaa")
    assert [es.name for es in hits] == ["NOAA 20 (JPSS-1)", "NOAA 21 (JPSS-2)"]
    assert bundled.search("98067A") == [] and bundled.search("1998-067A")
    assert len(list(bundled)) == len(bundled) == 343
    assert bundled.bundled and "old" in bundled.note and "2026-08-2" in bundled.note


def _with_epoch(text: str, day: str) -> str:
    out = []
    for line in text.splitlines():
        if line.startswith("1 "):
            line = line[:20] + day + line[32:68]
            line += str(compute_checksum(line))
        out.append(line)
    return "\n".join(out) + "\n"


def test_duplicates_keep_the_newest_epoch(tmp_path):
    text = (TLE_DATA / "amateur5.txt").read_text()
    old = tmp_path / "old.txt"
    new = tmp_path / "new.txt"
    old.write_text(_with_epoch(text, "200.00000000"))
    new.write_text(_with_epoch(text, "235.50000000"))
    for order in ([old, new], [new, old]):
        catalog = Catalog.load(order)
        assert len(catalog) == 5
        assert catalog.find("ISS").epoch == datetime(2026, 8, 23, 12, tzinfo=timezone.utc)
        assert catalog.groups == ["new", "old"]
        assert len(catalog.group("old")) == 5


def test_load_skips_bad_sets_with_warnings():
    seen: list[str] = []
    catalog = Catalog.load([TLE_DATA / "bad_checksum.txt", TLE_DATA / "truncated_line2.txt",
                            TLE_DATA / "amateur5.json"], on_warning=seen.append)
    assert len(seen) == 2 and len(catalog) == 5
    assert not catalog.bundled


def _only_broken(tmp_path: Path) -> Path:
    """The shifted-column ISS set of shifted_column.txt on its own (lines 4-6)."""
    bad = tmp_path / "only_bad.txt"
    lines = (TLE_DATA / "shifted_column.txt").read_text().splitlines()[3:6]
    bad.write_text("\n".join(lines) + "\n")
    return bad


def test_load_of_only_broken_sets_raises_the_first_fault(tmp_path):
    bad = _only_broken(tmp_path)
    seen: list[str] = []
    with pytest.raises(TleFormatError, match=r"^no usable element set: " + re.escape(str(bad))
                       + r":\d+: ") as info:
        Catalog.load([bad], on_warning=seen.append)
    assert seen == []  # the error replaces the warnings, it does not follow them
    assert "layout:" in str(info.value)  # a misplaced column shows the expected layout


def test_load_without_handler_warns_per_skipped_set():
    with pytest.warns(TleWarning, match="skipped a broken element set") as record:
        catalog = Catalog.load([TLE_DATA / "bad_checksum.txt", TLE_DATA / "amateur5.txt"])
    assert len(catalog) == 5 and len(record) == 1


def test_broken_cache_leaves_the_snapshot_not_an_error(tmp_path, bundled):
    store = TleStore(cache_dir=tmp_path, clock=ManualClock(T0))
    _only_broken(tmp_path)  # the store's cache dir now holds one all-broken file
    seen: list[str] = []
    catalog = Catalog.default(store, on_warning=seen.append)
    assert len(catalog) == len(bundled) and len(seen) >= 1


def test_default_unites_the_cache_and_the_snapshot(tmp_path, bundled):
    store = TleStore(cache_dir=tmp_path, clock=ManualClock(T0))
    assert Catalog.default(store).bundled
    (tmp_path / "mine.txt").write_bytes((TLE_DATA / "alpha5.txt").read_bytes())
    catalog = Catalog.default(store)
    assert not catalog.bundled and len(catalog) == len(bundled) + 2
    assert catalog.find("A0000").norad_id == 100000
    assert catalog.find("339999").name == "ALPHA FIVE HIGH"
    # one updated group hides none of the bundled ones
    assert catalog.find("NOAA 20 (JPSS-1)").norad_id == 43013
    assert len(catalog.group("weather")) == len(bundled.group("weather"))
    assert catalog.group_origins("mine") == ("cache",)
    assert catalog.group_origins("weather") == ("bundled",)


def test_the_freshest_set_of_an_object_wins(tmp_path, bundled):
    iss = bundled.find("ISS")
    newer = _with_epoch_day(iss, 300.5)   # 2026-10-27, after the snapshot
    older = _with_epoch_day(iss, 200.5)
    store = TleStore(cache_dir=tmp_path, clock=ManualClock(T0))
    (tmp_path / "stations.txt").write_text(newer)
    catalog = Catalog.default(store)
    assert catalog.find("ISS").epoch.timetuple().tm_yday == 300
    assert catalog.group_origins("stations") == ("bundled", "cache")
    (tmp_path / "stations.txt").write_text(older)
    assert Catalog.default(store).find("ISS").epoch == iss.epoch


def _with_epoch_day(es, day: float) -> str:
    """``es`` as 3LE text with its epoch moved to ``day`` of 2026 (checksum recomputed)."""
    line1 = es.line1[:18] + f"26{day:012.8f}" + es.line1[32:68]
    line1 += str(compute_checksum(line1))
    return f"{es.name}\n{line1}\n{es.line2}\n"


@pytest.mark.parametrize("typed", ["NOAA-20", "NOAA 20", "noaa20", "JPSS-1", "jpss 1",
                                   "NOAA 20 (JPSS-1)"])
def test_names_people_type_resolve(bundled, typed):
    assert bundled.find(typed).name == "NOAA 20 (JPSS-1)"


@pytest.mark.parametrize(("typed", "name"), [
    ("ISS", "ISS (ZARYA)"), ("SO-50", "SAUDISAT 1C (SO-50)"), ("so 50", "SAUDISAT 1C (SO-50)"),
    ("AO-7", "OSCAR 7 (AO-7)"), ("ao7", "OSCAR 7 (AO-7)"), ("NOAA-21", "NOAA 21 (JPSS-2)"),
])
def test_short_names_resolve(bundled, typed, name):
    assert bundled.find(typed).name == name


def test_did_you_mean_only_when_nothing_matches(bundled):
    with pytest.raises(UnknownSatelliteError, match="did you mean"):
        bundled.find("NOAA-19")   # not in the snapshot: the close names are offered


def test_age_warning_thresholds(bundled):
    iss = bundled.find("ISS")
    assert age_warning(iss, iss.epoch + timedelta(days=6.9)) is None
    mild = age_warning(iss, iss.epoch + timedelta(days=8))
    assert mild.startswith("elements for ISS (ZARYA) are 8.0 days old (epoch 2026-08-22 12:00")
    loud = age_warning(iss, iss.epoch + timedelta(days=45))
    assert loud.startswith("WARNING: elements for ISS (ZARYA) are 45 days old")
    assert "tracker tle update" in mild and "tracker tle update" in loud


def test_elements_from_the_future_of_the_time_asked_are_flagged(bundled):
    iss = bundled.find("ISS")
    assert age_warning(iss, iss.epoch - timedelta(days=6)) is None
    mild = age_warning(iss, iss.epoch - timedelta(days=10))
    assert mild.startswith("elements for ISS (ZARYA) are from 10 days after the time asked")
    loud = age_warning(iss, iss.epoch - timedelta(days=365))
    assert loud.startswith("WARNING: elements for ISS (ZARYA) are from 365 days after")


def test_many_stale_sets_get_one_summary_line(bundled):
    sets = list(bundled.group("amateur"))
    later = max(es.epoch for es in sets) + timedelta(days=60)
    (line,) = age_warnings(sets, later)
    assert line.startswith(f"WARNING: {len(sets)} of {len(sets)} element sets are more than 7")
    assert len(age_warnings(sets[:3], later)) == 3
