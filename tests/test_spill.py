"""RowSpill: rows kept by spans of a field, in memory (one span) or in temporary files."""

from __future__ import annotations

import os

import numpy as np

from tracker.spill import RowSpill

DTYPE = np.dtype([("t", np.float64), ("k", np.int32)])


def rows(ts):
    out = np.zeros(len(ts), DTYPE)
    out["t"], out["k"] = ts, np.arange(len(ts))
    return out


def test_spans_on_disk_come_back_in_span_order_and_leave_no_file():
    with RowSpill(DTYPE, "t", 0.0, 100.0, 4) as spill:
        folder = spill.dir.name
        spill.add(rows([90.0, 10.0, 55.0, -5.0]))
        spill.add(rows([]))
        spill.add(rows([30.0, 120.0, 12.0]))
        assert len(os.listdir(folder)) == 4
        got = [list(part["t"]) for part in spill.spans()]
        assert os.listdir(folder) == []  # each span's file goes as it is read
    assert got == [[10.0, -5.0, 12.0], [30.0], [55.0], [90.0, 120.0]]
    assert not os.path.exists(folder)


def test_one_span_stays_in_memory():
    with RowSpill(DTYPE, "t", 0.0, 100.0, 1) as spill:
        assert spill.dir is None
        spill.add(rows([5.0, 1.0]))
        spill.add(rows([3.0]))
        assert [list(p["t"]) for p in spill.spans()] == [[5.0, 1.0, 3.0]]
    with RowSpill(DTYPE, "t", 0.0, 100.0, 1) as spill:
        assert list(spill.spans()) == []


def test_a_temporary_folder_that_cannot_take_the_rows_is_one_clear_error(tmp_path, monkeypatch):
    import shutil
    import tempfile

    import pytest

    from tracker.errors import ConfigError

    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    monkeypatch.setattr(tempfile, "tempdir", str(not_a_folder))
    with pytest.raises(ConfigError, match=r"temporary folder .*file .*set TMPDIR"):
        RowSpill(DTYPE, "t", 0.0, 100.0, 4).__enter__()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with RowSpill(DTYPE, "t", 0.0, 100.0, 4) as spill:
        shutil.rmtree(spill.dir.name)            # the folder gone (or full) under the run
        with pytest.raises(ConfigError, match="cannot keep rows of a large result"):
            spill.add(rows([10.0]))
        os.mkdir(spill.dir.name)                 # for the clean-up


def test_rows_in_memory_are_gathered_in_one_array_past_the_hint():
    # Room for two rows reserved; five come: the array grows, nothing is lost or reordered,
    # and the span given back is that one array (no copy of all the rows).
    with RowSpill(DTYPE, "t", 0.0, 100.0, 1, rows_hint=2) as spill:
        assert len(spill.mem) == 2
        for batch in ([5.0], [1.0, 7.0], [], [3.0, 2.0]):
            spill.add(rows(batch))
        kept = spill.mem
        (part,) = spill.spans()
    assert list(part["t"]) == [5.0, 1.0, 7.0, 3.0, 2.0]
    assert np.shares_memory(part, kept)
