"""Rows of a numpy structured array kept by spans of one field's value, on disk when large.

The batch finder's streamed result (:func:`tracker.batch.iter_passes_batch`) gathers its pass
rows here while the search runs and gives them back span by span (AOS times), so the rows of
a result of any size are never all in memory. With one span the rows stay in memory; with
more, each span is a temporary file (removed as it is read, and with the folder on close).
Rows kept in memory are copied into one array as they come (grown by doubling), so giving
them back needs no second copy of them all.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator

import numpy as np

from tracker.errors import ConfigError


class RowSpill:
    """Rows of ``dtype`` collected by the value of ``field``: ``n`` equal spans of
    [``lo``, ``hi``] (values outside go to the first or last span). ``rows_hint``: about how
    many rows to expect with one span (room for them is reserved, but memory is only taken
    as they come; more are taken too)."""

    def __init__(self, dtype: np.dtype, field: str, lo: float, hi: float, n: int,
                 rows_hint: int = 0):
        self.dtype, self.field = dtype, field
        self.n = max(1, int(n))
        self.inner = np.linspace(lo, hi, self.n + 1)[1:-1]
        self.mem = np.empty(max(0, int(rows_hint)) if self.n == 1 else 0, dtype)
        self.n_mem = 0  # rows of mem in use
        self.dir: tempfile.TemporaryDirectory | None = None

    def __enter__(self) -> RowSpill:
        if self.n > 1:
            try:
                self.dir = tempfile.TemporaryDirectory(prefix="tracker-rows-")
            except OSError as e:
                raise _no_room(tempfile.gettempdir(), e) from None
        return self

    def __exit__(self, *exc) -> None:
        if self.dir is not None:
            self.dir.cleanup()

    def _path(self, k: int) -> str:
        assert self.dir is not None
        return os.path.join(self.dir.name, f"{k}.bin")

    def add(self, rows: np.ndarray) -> None:
        if self.dir is None:
            end = self.n_mem + len(rows)
            if end > len(self.mem):
                # np.empty: the pages of the spare room are only taken once written.
                grown = np.empty(max(end, 2 * len(self.mem), 4096), self.dtype)
                grown[:self.n_mem] = self.mem[:self.n_mem]
                self.mem = grown
            self.mem[self.n_mem:end] = rows
            self.n_mem = end
            return
        span = np.searchsorted(self.inner, rows[self.field], "right")
        order = np.argsort(span, kind="stable")
        cuts = np.searchsorted(span[order], np.arange(self.n + 1))
        try:
            for k in np.flatnonzero(np.diff(cuts)).tolist():
                with open(self._path(k), "ab") as f:
                    rows[order[cuts[k]:cuts[k + 1]]].tofile(f)
        except OSError as e:
            raise _no_room(self.dir.name, e) from None

    def spans(self) -> Iterator[np.ndarray]:
        """Each non-empty span's rows, first span first (in the order they were added)."""
        if self.dir is None:
            rows, self.mem, self.n_mem = self.mem[:self.n_mem], np.zeros(0, self.dtype), 0
            if len(rows):
                yield rows
            return
        for k in range(self.n):
            path = self._path(k)
            if os.path.exists(path):
                rows = np.fromfile(path, dtype=self.dtype)
                os.remove(path)
                yield rows


def _no_room(folder: str, e: OSError) -> ConfigError:
    return ConfigError(f"cannot keep rows of a large result in the temporary folder {folder} "
                       f"({e.strerror}); free space there or set TMPDIR to a folder with room")
