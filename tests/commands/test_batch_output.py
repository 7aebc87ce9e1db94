"""``tracker batch`` output written in parts: the same bytes as written whole, Parquet, and
no partial file when writing fails half way."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from _paths import DATA

import tracker.commands.batch as batch_cmd
from tracker.cli import main
from tracker.export import PASS_FIELDS

AT = "2026-03-19T04:51Z"
SAMPLE = str(DATA / "batch_active_sample.txt")  # 322 objects of the active catalogue
STATIONS = "name,lat_deg,lon_deg,alt_m,min_el_deg\nDelft,52.0,4.37,10,0\nQuito,-0.2,-78.5,2850,5\n"

pytestmark = pytest.mark.usefixtures("isolated_home")


def batch_args(tmp_path, fmt: str, *extra: str) -> list[str]:
    stations = tmp_path / "stations.csv"
    stations.write_text(STATIONS)
    return ["batch", SAMPLE, "--stations", str(stations), "--days", "0.5", "--at", AT,
            "--format", fmt, *extra]


def without_elapsed(data: bytes) -> bytes:
    # meta.elapsed_s is the run's own duration: the one value two runs never share.
    return b"\n".join(x for x in data.split(b"\n") if b'"elapsed_s"' not in x)


@pytest.mark.parametrize("fmt", ["csv", "json", "table", "ics"])
def test_output_in_parts_is_byte_identical_to_whole(monkeypatch, capsys, tmp_path, fmt):
    outputs = []
    for rows in (10**9, 7):  # one part; parts of 7 passes (hundreds of parts)
        monkeypatch.setattr(batch_cmd, "ROWS_PER_PART", rows)
        out = tmp_path / f"{rows}.{fmt}"
        assert main(batch_args(tmp_path, fmt, "--min-max-el", "20", "--rotator", "G-5500",
                               "--out", str(out))) == 0, capsys.readouterr().err
        outputs.append(without_elapsed(out.read_bytes()))
    whole, parts = outputs
    assert whole.count(b"\n") > 30  # enough passes for several parts
    assert parts == whole
    if fmt == "csv":  # sorted by AOS across the parts, as the table is
        aos = [line.split(b",")[3] for line in whole.splitlines()[1:]]
        assert aos == sorted(aos)


def test_stdout_in_parts_matches_the_file(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(batch_cmd, "ROWS_PER_PART", 5)
    out = tmp_path / "p.json"
    assert main(batch_args(tmp_path, "json", "--out", str(out))) == 0
    capsys.readouterr()
    assert main(batch_args(tmp_path, "json")) == 0
    stdout = capsys.readouterr().out
    assert without_elapsed(stdout.encode()) == without_elapsed(out.read_bytes())
    assert len(json.loads(stdout)["passes"]) > 10


def test_failure_while_writing_leaves_no_file(monkeypatch, capsys, tmp_path):
    real = batch_cmd.record_parts

    def failing(table, plans, rows=None):
        parts = real(table, plans, 3)
        yield next(parts)
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(batch_cmd, "record_parts", failing)
    out = tmp_path / "p.csv"
    with pytest.raises(RuntimeError, match="disk on fire"):
        main(batch_args(tmp_path, "csv", "--out", str(out)))
    assert list(tmp_path.iterdir()) == [tmp_path / "stations.csv"]


def test_parquet_round_trip(monkeypatch, capsys, tmp_path):
    pytest.importorskip("pyarrow", reason="Parquet needs the optional pyarrow "
                                          "(extra 'parquet')")
    import pyarrow.parquet as pq

    monkeypatch.setattr(batch_cmd, "ROWS_PER_PART", 50)
    pq_file, js_file = tmp_path / "p.parquet", tmp_path / "p.json"
    common = ("--min-max-el", "20", "--rotator", "G-5500")
    assert main(batch_args(tmp_path, "parquet", *common, "--out", str(pq_file))) == 0
    assert main(batch_args(tmp_path, "json", *common, "--out", str(js_file))) == 0
    doc = json.loads(js_file.read_text())
    table = pq.read_table(pq_file)
    assert table.column_names == list(PASS_FIELDS)
    assert table.to_pylist() == doc["passes"]
    assert pq.ParquetFile(pq_file).num_row_groups > 1  # written part by part
    stored = json.loads(table.schema.metadata[b"rotator-tracker"])
    assert stored["schema"] == doc["schema"] and stored["errors"] == doc["errors"]
    assert {k: v for k, v in stored["meta"].items() if k != "elapsed_s"} == {
        k: v for k, v in doc["meta"].items() if k != "elapsed_s"}


def test_parquet_needs_out(capsys, tmp_path):
    assert main(batch_args(tmp_path, "parquet")) == 2
    err = capsys.readouterr().err
    assert "--format parquet needs --out FILE" in err and err.count("\n") == 1


def test_parquet_without_pyarrow_is_one_clear_line(tmp_path):
    # None in sys.modules makes ``import pyarrow`` fail exactly as when it is not installed.
    code = ("import sys; sys.modules['pyarrow'] = None; "
            "from tracker.cli import main; sys.exit(main(sys.argv[1:]))")
    out = tmp_path / "p.parquet"
    proc = subprocess.run([sys.executable, "-c", code, *batch_args(tmp_path, "parquet"),
                           "--out", str(out)], capture_output=True, text=True, timeout=120,
                          env={"PATH": "/usr/bin:/bin", "XDG_CONFIG_HOME": str(tmp_path),
                               "XDG_CACHE_HOME": str(tmp_path), "HOME": str(tmp_path),
                               "PYTHONPATH": ":".join(sys.path)})
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == ("tracker: error: Parquet output needs pyarrow, which is not "
                           "installed: pip install 'rotator-tracker[parquet]'\n")
    assert not out.exists()


@pytest.fixture
def inproc_cluster():
    """Two in-process Dask workers at an ``inproc://`` address: --dask ADDRESS reaches them
    from main() in this process, quickly and without spawning processes."""
    distributed = pytest.importorskip("dask.distributed")
    pytest.importorskip("pyarrow")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_dask_writes_a_partitioned_folder_equal_to_the_file(capsys, tmp_path, inproc_cluster):
    import pyarrow.dataset as ds
    import pyarrow.parquet as pq

    single, folder = tmp_path / "p.parquet", tmp_path / "parts"
    common = ("--min-max-el", "10", "--visible")
    assert main(batch_args(tmp_path, "parquet", *common, "--out", str(single))) == 0
    capsys.readouterr()
    assert main(batch_args(tmp_path, "parquet", *common, "--out", f"{folder}/",
                           "--dask", inproc_cluster)) == 0
    err = capsys.readouterr().err
    assert f"tracker: wrote {folder} (1 part)" in err
    assert sorted(p.name for p in folder.iterdir()) == ["_common_metadata",
                                                        "part-00000.parquet"]
    whole, parts = pq.read_table(single), ds.dataset(folder).to_table()
    assert parts.num_rows == whole.num_rows > 10 and all(parts.column("visible").to_pylist())
    assert parts.to_pydict() == whole.to_pydict()
    stored = json.loads(whole.schema.metadata[b"rotator-tracker"])
    common_meta = json.loads(pq.read_schema(folder / "_common_metadata")
                             .metadata[b"rotator-tracker"])
    assert common_meta["errors"] == stored["errors"]
    own = ("elapsed_s", "parts", "passes")  # the run's duration; what only a folder has
    assert {k: v for k, v in common_meta["meta"].items() if k not in own} == {
        k: v for k, v in stored["meta"].items() if k not in own}
    assert common_meta["meta"]["parts"] == 1
    assert common_meta["meta"]["passes"] == whole.num_rows


def test_a_non_empty_folder_is_refused_in_one_line_before_the_search(capsys, tmp_path,
                                                                     inproc_cluster):
    folder = tmp_path / "parts"
    folder.mkdir()
    (folder / "part-00000.parquet").write_bytes(b"old")
    argv = batch_args(tmp_path, "parquet", "--out", f"{folder}/", "--dask", inproc_cluster)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err == (f"tracker: error: --out {folder}/ already exists and is not empty; not "
                   f"writing into it (add --force to replace it, or choose another name)\n")
    assert (folder / "part-00000.parquet").read_bytes() == b"old"
    assert main([*argv, "--force"]) == 0
    assert (folder / "part-00000.parquet").read_bytes()[:4] == b"PAR1"


def test_a_plot_needs_the_passes_in_one_place(capsys, tmp_path, inproc_cluster):
    argv = batch_args(tmp_path, "parquet", "--out", f"{tmp_path}/parts/", "--dask",
                      inproc_cluster, "--plot", str(tmp_path / "t.png"))
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--plot needs every pass in this process" in err and err.count("\n") == 1
    assert not (tmp_path / "parts").exists()
