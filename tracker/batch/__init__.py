"""Batch planning at catalogue and network scale: the public entry points.

* :func:`find_passes_batch` - every pass of many satellites over many stations (vectorised
  SGP4 + numpy; see :mod:`tracker.batch.finder` for the method) -> :class:`PassTable`.
* :func:`iter_passes_batch` - the same table in parts, memory bounded whatever its size.
* :func:`find_passes_dask` - the same job split into chunks on a dask.distributed cluster
  (:mod:`tracker.batch.distributed`); :func:`write_passes_dask` has the workers write the
  passes as a partitioned Parquet result instead (one file per chunk,
  :mod:`tracker.batch.output`).
* :func:`select_passes` - the passes a user keeps (minimum max elevation, sunlit/visible).
* :func:`load_stations` - a stations file (CSV or TOML, format in :mod:`tracker.batch.inputs`).
* :func:`pass_track` / :func:`plan_summaries` - the sky track of a pass and the planner's
  summary (mode, predicted max error, pre-position time) for passes worth planning
  (:mod:`tracker.batch.summaries`).

The frames and look angles the finder works in are in :mod:`tracker.batch.geometry`.
"""

from __future__ import annotations

from tracker.batch.distributed import PartitionedResult, find_passes_dask, write_passes_dask
from tracker.batch.finder import (
    PASS_DTYPE,
    PassTable,
    SatError,
    find_passes_batch,
    iter_passes_batch,
    merge_tables,
)
from tracker.batch.inputs import load_stations, satrecs_of, split_by_epoch
from tracker.batch.output import select_passes
from tracker.batch.summaries import pass_track, plan_summaries

__all__ = [
    "PASS_DTYPE", "PartitionedResult", "PassTable", "SatError", "find_passes_batch",
    "find_passes_dask", "iter_passes_batch", "load_stations", "merge_tables", "pass_track",
    "plan_summaries", "satrecs_of", "select_passes", "split_by_epoch", "write_passes_dask",
]
