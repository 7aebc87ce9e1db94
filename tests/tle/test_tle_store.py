"""The element cache against a real http.server on 127.0.0.1 (no mocked network)."""

from __future__ import annotations

import json
import re
from datetime import datetime, timezone

import pytest
from _celestrak import LAST_MODIFIED

from tle.cachedir import default_cache_dir
from tle.catalog import Catalog
from tle.errors import TleFetchError
from tle.store import TleStore, resolve_source
from tracker.clock import ManualClock

T0 = datetime(2026, 8, 23, 12, tzinfo=timezone.utc)


@pytest.fixture
def clock():
    return ManualClock(T0)


def make_store(tmp_path, celestrak, clock, **kw):
    return TleStore(cache_dir=tmp_path / "cache", clock=clock, base_url=celestrak.base_url,
                    timeout_s=kw.pop("timeout_s", 5.0), **kw)


def test_group_urls_and_names():
    s = resolve_source("amateur")
    assert s.url == "https://celestrak.org/NORAD/elements/gp.php?GROUP=amateur&FORMAT=tle"
    assert resolve_source("amateur", fmt="json").url.endswith("GROUP=amateur&FORMAT=json")
    assert resolve_source("https://x.org/gp.php?GROUP=cubesat&FORMAT=tle").name == "cubesat"
    assert resolve_source("https://x.org/files/my%20sats.txt").name == "my_sats"
    with pytest.raises(Exception, match="neither a CelesTrak group name"):
        resolve_source("bad group!")


def test_cache_dir_from_env(monkeypatch, tmp_path):
    monkeypatch.setenv("TRACKER_CACHE_DIR", str(tmp_path))
    assert default_cache_dir() == tmp_path / "tle"
    assert TleStore().cache_dir == tmp_path / "tle"


def test_update_writes_file_and_metadata(tmp_path, celestrak, clock):
    store = make_store(tmp_path, celestrak, clock)
    (result,) = store.update(["amateur"])
    assert (result.status, result.count) == ("updated", 5)
    path = store.cache_dir / "amateur.txt"
    assert path.read_bytes() == celestrak.body
    meta = json.loads(store.meta_path.read_text())["amateur"]
    assert meta["url"] == f"{celestrak.base_url}?GROUP=amateur&FORMAT=tle"
    assert meta["etag"] == '"v1"' and meta["last_modified"] == LAST_MODIFIED
    assert meta["count"] == 5 and meta["last_check"] == T0.timestamp()
    assert store.paths() == [path]
    assert not [p for p in store.cache_dir.iterdir() if p.name.startswith(".")]


def test_two_hour_rule_then_conditional_304(tmp_path, celestrak, clock):
    store = make_store(tmp_path, celestrak, clock)
    store.update(["amateur"])
    clock.advance(3600)
    (fresh,) = store.update(["amateur"])
    assert fresh.status == "fresh" and "--force" in fresh.message
    assert len(celestrak.requests) == 1  # no request inside 2 hours
    clock.advance(3601)
    (again,) = store.update(["amateur"])
    assert again.status == "not modified" and again.count == 5
    headers = celestrak.requests[-1][1]
    assert headers["if-none-match"] == '"v1"'
    assert headers["if-modified-since"] == LAST_MODIFIED
    meta = json.loads(store.meta_path.read_text())["amateur"]
    assert meta["last_check"] == clock.timestamp()  # the 304 refreshed the check time
    (forced,) = store.update(["amateur"], force=True)
    assert forced.status == "not modified" and len(celestrak.requests) == 3


@pytest.mark.parametrize(("how", "message"), [
    ("404", "HTTP 404 Not Found; cached copy kept"),
    ("html", "is an HTML page, not element sets"),
    ("empty", "is empty; rejected"),
    ("nodata", "the server says 'No GP data found'"),
    ("cut", "truncated download"),
    ("cut-clean", "does not parse (truncated or damaged?): amateur (downloaded):15: "
                  "'FUNCUBE-1 (AO-73)' line 2: 31 characters long"),
])
def test_bad_downloads_are_rejected_and_the_copy_is_kept(tmp_path, celestrak, clock, how,
                                                         message):
    store = make_store(tmp_path, celestrak, clock)
    store.update(["amateur"])
    before = (store.cache_dir / "amateur.txt").read_bytes()
    meta_before = store.meta_path.read_text()
    celestrak.behaviour["amateur"] = how
    with pytest.raises(TleFetchError, match=re.escape(message)):
        store.update(["amateur"], force=True)
    assert (store.cache_dir / "amateur.txt").read_bytes() == before
    assert store.meta_path.read_text() == meta_before
    assert len(Catalog.load(store.paths())) == 5


def test_slow_server_times_out(tmp_path, celestrak, clock):
    celestrak.behaviour["weather"] = "slow"
    store = make_store(tmp_path, celestrak, clock, timeout_s=0.3)
    with pytest.raises(TleFetchError, match=r"no complete answer within 0\.3 s .*cached copy kept"):
        store.update(["weather"])
    assert store.paths() == []


def test_no_server_is_a_clear_error(tmp_path, clock):
    store = TleStore(cache_dir=tmp_path, clock=clock, base_url="http://127.0.0.1:9/gp.php",
                     timeout_s=2.0)
    with pytest.raises(TleFetchError, match=r"cannot connect .*no network\? cached copy kept"):
        store.update(["amateur"])


def test_one_failure_does_not_stop_the_others(tmp_path, celestrak, clock):
    celestrak.behaviour["missing"] = "404"
    store = make_store(tmp_path, celestrak, clock)
    seen = []
    with pytest.raises(TleFetchError, match="HTTP 404"):
        store.update(["missing", "amateur"], on_result=seen.append)
    assert [r.status for r in seen] == ["failed", "updated"]
    assert [p.name for p in store.paths()] == ["amateur.txt"]


def test_omm_json_group_and_list(tmp_path, celestrak, clock):
    celestrak.behaviour["stations"] = "json"
    store = make_store(tmp_path, celestrak, clock)
    store.update(["amateur"])
    store.update(["stations"], fmt="json")
    clock.advance(1800)
    infos = {i.name: i for i in store.list()}
    assert set(infos) == {"amateur", "stations"}
    assert infos["stations"].path.name == "stations.json" and infos["stations"].count == 5
    assert infos["amateur"].checked_age_s == pytest.approx(1800)
    assert 0.5 < infos["amateur"].median_epoch_age_days < 2.0
    catalog = Catalog.default(store)
    assert not catalog.bundled and {"amateur", "stations"} <= set(catalog.groups)
    assert catalog.group_origins("stations") == ("bundled", "cache")
    assert catalog.find("ISS").omm is not None or catalog.find("ISS").line1 is not None


def test_empty_store_lists_nothing(tmp_path, clock):
    store = TleStore(cache_dir=tmp_path / "none", clock=clock)
    assert store.list() == [] and store.paths() == []
    assert Catalog.default(store).bundled


def test_metadata_nested_past_the_parser_is_one_clean_error(tmp_path):
    from tle.errors import TleError

    store = TleStore(cache_dir=tmp_path / "cache")
    store.cache_dir.mkdir()
    store.meta_path.write_text("[" * 100_000)
    with pytest.raises(TleError, match="unreadable cache metadata"):
        store.list()
