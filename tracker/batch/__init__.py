"""Batch planning at catalogue and network scale: the public entry points.

* :func:`find_passes_batch` - every pass of many satellites over many stations (vectorised
  SGP4 + numpy; see :mod:`tracker.batch.finder` for the method) -> :class:`PassTable`.
* :func:`iter_passes_batch` - the same table in parts, memory bounded whatever its size.
* :func:`find_passes_dask` - the same job split into chunks on a dask.distributed cluster
  (:mod:`tracker.batch.distributed`).
* :func:`load_stations` - a stations file (CSV or TOML, format in :mod:`tracker.batch.inputs`).
* :func:`pass_track` / :func:`plan_summaries` - the sky track of a pass and the planner's
  summary (mode, predicted max error, pre-position time) for passes worth planning
  (:mod:`tracker.batch.summaries`).

The frames and look angles the finder works in are in :mod:`tracker.batch.geometry`.
"""

from __future__ import annotations

from tracker.batch.distributed import find_passes_dask
from tracker.batch.finder import (
    PASS_DTYPE,
    PassTable,
    SatError,
    find_passes_batch,
    iter_passes_batch,
    merge_tables,
)
from tracker.batch.inputs import load_stations, satrecs_of, split_by_epoch
from tracker.batch.summaries import pass_track, plan_summaries

__all__ = [
    "PASS_DTYPE", "PassTable", "SatError", "find_passes_batch", "find_passes_dask",
    "iter_passes_batch", "load_stations", "merge_tables", "pass_track", "plan_summaries",
    "satrecs_of", "split_by_epoch",
]
