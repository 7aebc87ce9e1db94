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


# Partitioned Parquet written by the workers ---------------------------------------------


def read_sorted(source):
    """A Parquet file or partitioned folder as one table, sorted (rows of equal AOS, such as
    the passes clipped at the window start, in a fixed order)."""
    import pyarrow.dataset as ds

    table = ds.dataset(source).to_table()
    return table.sort_by([("aos_s", "ascending"), ("target", "ascending"),
                          ("station", "ascending")])


def test_partitioned_parquet_reads_back_as_the_single_file(tmp_path):
    pytest.importorskip("pyarrow")
    import json

    import pyarrow.parquet as pq

    from tracker.batch import write_passes_dask
    from tracker.export import error_records, pass_records, write_parquet

    elements = sets()
    end = START + timedelta(days=1)
    local = find_passes_batch([Satrec.twoline2rv(a, b) for _, a, b in elements],
                              [n for n, _, _ in elements], STATIONS, START, end)
    single = tmp_path / "single.parquet"
    write_parquet([pass_records(local)], single, errors=error_records(local.errors))
    folder = tmp_path / "parts"
    result = write_passes_dask(elements, STATIONS, START, end, folder, chunk_sats=70,
                               n_workers=2, processes=False, meta={"source": "sample"},
                               rows_per_group=100)
    assert [p.name for p in result.files] == [f"part-0000{k}.parquet" for k in range(5)]
    assert sorted(p.name for p in folder.iterdir()) == [
        "_common_metadata", *(p.name for p in result.files)]
    assert all(pq.ParquetFile(p).num_row_groups > 1 for p in result.files[:4])
    parts, whole = read_sorted(folder), read_sorted(single)
    assert parts.num_rows == whole.num_rows == result.n_passes == len(local) > 1000
    assert parts.schema.equals(whole.schema, check_metadata=False)
    assert parts.to_pydict() == whole.to_pydict()
    assert result.errors == local.errors
    common = json.loads(pq.read_schema(folder / "_common_metadata").metadata[b"rotator-tracker"])
    assert common["errors"] == error_records(local.errors)
    assert common["meta"]["source"] == "sample" and common["meta"]["parts"] == 5
    assert common["meta"]["passes"] == len(local)
    part = json.loads(pq.read_schema(result.files[0]).metadata[b"rotator-tracker"])
    assert part["meta"] == {"source": "sample", "parts": 5}


def test_partitioned_output_keeps_the_selected_passes_with_plans(tmp_path):
    pytest.importorskip("pyarrow")
    from tracker.batch import plan_summaries, select_passes, write_passes_dask
    from tracker.export import pass_records, write_parquet
    from tracker.mount import preset

    elements = sets()[:40]
    end = START + timedelta(hours=12)
    satrecs = [Satrec.twoline2rv(a, b) for _, a, b in elements]
    local = select_passes(find_passes_batch(satrecs, [n for n, _, _ in elements], STATIONS,
                                            START, end), 30.0, "sunlit")
    spec = preset("G-5500")
    write_parquet([pass_records(local, plan_summaries(local, dict(enumerate(satrecs)), spec,
                                                      30.0))], tmp_path / "single.parquet")
    write_passes_dask(elements, STATIONS, START, end, tmp_path / "out", chunk_sats=15,
                      n_workers=2, processes=False, min_max_el_deg=30.0, only="sunlit",
                      rotator=spec)
    got = read_sorted(tmp_path / "out")
    assert got.to_pydict() == read_sorted(tmp_path / "single.parquet").to_pydict()
    assert got.num_rows == len(local) > 5
    assert min(got.column("max_el_deg").to_pylist()) >= 30.0
    assert all(got.column("sunlit").to_pylist())
    assert {"normal", "flip"} <= set(got.column("plan_mode").to_pylist())


def test_a_failed_chunk_leaves_no_folder_behind(tmp_path, monkeypatch):
    pytest.importorskip("pyarrow")
    import tracker.batch.distributed as distributed
    from tracker.batch import write_passes_dask

    real = distributed._run_chunk

    def failing(lines, *args):
        if lines[0][0] == sets()[30][0]:
            raise RuntimeError("worker lost")
        return real(lines, *args)

    monkeypatch.setattr(distributed, "_run_chunk", failing)  # in-process workers see it
    with pytest.raises(RuntimeError, match="worker lost"):
        write_passes_dask(sets(), STATIONS, START, START + timedelta(hours=6),
                          tmp_path / "out", chunk_sats=30, n_workers=2, processes=False)
    assert list(tmp_path.iterdir()) == []


def test_a_folder_with_files_is_refused_and_force_replaces_only_a_result(tmp_path):
    pytest.importorskip("pyarrow")
    from tracker.batch import write_passes_dask
    from tracker.errors import OutputExistsError

    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "part-00007.parquet").write_bytes(b"an older run")
    window = (START, START + timedelta(hours=2))
    with pytest.raises(OutputExistsError, match="already exists and is not empty"):
        write_passes_dask(sets()[:5], STATIONS, *window, folder, processes=False)
    write_passes_dask(sets()[:5], STATIONS, *window, folder, processes=False, force=True)
    assert sorted(p.name for p in folder.iterdir()) == ["_common_metadata",
                                                         "part-00000.parquet"]
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match=r"not a partitioned pass result \(notes.txt\)"):
        write_passes_dask(sets()[:5], STATIONS, *window, folder, processes=False, force=True)
    assert (folder / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder
