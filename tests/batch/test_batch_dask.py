"""The Dask backend gives the same table as the local path (2-worker LocalCluster)."""

from __future__ import annotations

from datetime import datetime, timedelta, timezone

import numpy as np
import pytest
from _paths import DATA
from sgp4.api import Satrec

from tracker.batch import find_passes_batch, find_passes_dask
from tracker.errors import ConfigError
from tracker.station import Station

pytest.importorskip("dask.distributed")

START = datetime(2026, 3, 19, 4, 51, tzinfo=timezone.utc)
STATIONS = [Station("Boulder", 40.0, -105.3, 1650.0), Station("Delft", 52.0, 4.37, 10.0, 5.0)]


def sets():
    path = DATA / "batch_active_sample.txt"
    lines = [x.strip() for x in path.read_text().splitlines() if x.strip()]
    return [(lines[i], lines[i + 1], lines[i + 2]) for i in range(0, len(lines) - 2, 3)]


def assert_identical(a, b):
    assert a.passes.dtype == b.passes.dtype and len(a.passes) == len(b.passes)
    for key in a.passes.dtype.names:
        assert np.array_equal(a.passes[key], b.passes[key]), key
    assert a.errors == b.errors


def test_dask_local_cluster_matches_local_path():
    elements = sets()
    end = START + timedelta(days=1)
    local = find_passes_batch([Satrec.twoline2rv(a, b) for _, a, b in elements],
                              [n for n, _, _ in elements], STATIONS, START, end)
    dist = find_passes_dask(elements, STATIONS, START, end, chunk_sats=70, n_workers=2,
                            processes=False)
    assert dist.stats["dask_chunks"] == 5
    assert_identical(local, dist)
    assert len(local.passes) > 1000


def test_dask_cli_on_a_process_cluster(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    from tracker.cli import main

    common = ["batch", "amateur", "--lat", "52", "--lon", "4.37", "--at", "2026-08-22T13:45Z",
              "--format", "csv"]
    assert main(common) == 0
    local = capsys.readouterr().out
    assert main([*common, "--dask"]) == 0
    assert capsys.readouterr().out == local


def test_unreachable_scheduler_is_a_clear_error():
    with pytest.raises(ConfigError, match="cannot reach the Dask scheduler"):
        find_passes_dask(sets()[:3], STATIONS, START, START + timedelta(hours=1),
                         address="tcp://127.0.0.1:9", connect_timeout_s=1.0)


@pytest.mark.parametrize("address", ["foo:bar", "xyz://host:1"])
def test_malformed_scheduler_address_is_a_clear_error(address):
    with pytest.raises(ConfigError, match="not a scheduler address"):
        find_passes_dask(sets()[:3], STATIONS, START, START + timedelta(hours=1),
                         address=address, connect_timeout_s=1.0)
