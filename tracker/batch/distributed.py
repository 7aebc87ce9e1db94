"""Dask backend: the batch job split into satellite chunks on a dask.distributed cluster.

Satellites are independent in the finder, so each chunk runs the ordinary local finder on a
worker. :func:`find_passes_dask` gathers the tables, re-indexes and merges them: the result is
identical to the local path. :func:`write_passes_dask` instead has each worker write its
chunk's passes as one Parquet file of a partitioned result (:mod:`tracker.batch.output`):
the passes never travel to the client, only counts and errors do. Elements travel as TLE
lines (sgp4's ``Satrec`` cannot be pickled) and are parsed on the worker. dask is an optional
dependency (extra ``dask``).
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from tracker.batch.output import (
    PART_NAME,
    check_only,
    check_output_dir,
    commit_parts_folder,
    new_parts_folder,
    select_passes,
    write_common_metadata,
    write_part,
)
from tracker.errors import ConfigError

ROWS_PER_GROUP = 20_000  # passes per Parquet row group (as tracker batch writes a file)
# After a failed chunk, how long the chunks still running may take to finish their parts.
SETTLE_TIMEOUT_S = 600.0


def _lines_of(elements) -> list[tuple[str, str, str]]:
    out = []
    for e in elements:
        if isinstance(e, tuple):
            out.append((str(e[0]), str(e[1]), str(e[2])))
        elif getattr(e, "line1", None) and getattr(e, "line2", None):
            out.append((e.name, e.line1, e.line2))
        else:
            raise ConfigError(f"{getattr(e, 'name', e)!r}: the Dask backend needs TLE lines "
                              f"(OMM-only element sets are not supported there)")
    return out


def _run_chunk(lines, stations, start, end, min_el_deg, kwargs):
    from tracker.batch.finder import find_passes_batch

    return find_passes_batch(_satrecs(lines), [n for n, _, _ in lines], stations, start, end,
                             min_el_deg, **kwargs)


def _satrecs(lines):
    from sgp4.api import Satrec

    return [Satrec.twoline2rv(a, b) for _, a, b in lines]


def _not_an_address(address: str, e: Exception) -> ConfigError:
    return ConfigError(f"address {address}: not a scheduler address ({e}); give e.g. "
                       f"tcp://host:8786, or no address for a local cluster")


def _check_address(address: str) -> None:
    """A malformed address is refused before any connection attempt: left to the client,
    a slow start of its event loop could time out first and blame the network."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(address)
        get_backend(scheme)
        if scheme in ("tcp", "tls", "ws", "wss"):
            parse_host_port(location, 8786)
    except (ValueError, TypeError) as e:
        raise _not_an_address(address, e) from None


def _client(address: str | None, n_workers: int, processes: bool, timeout_s: float,
            caller: str = "find_passes_dask"):
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError(f"{caller} needs dask.distributed: pip install "
                          "'rotator-tracker[dask]'") from None
    if address:
        _check_address(address)
        try:
            return Client(address, timeout=f"{timeout_s}s"), None
        except OSError as e:
            raise ConfigError(f"cannot reach the Dask scheduler at {address}: {e}") from None
        except (ValueError, TypeError) as e:
            # distributed parses the address itself; a typo (bad port, unknown scheme)
            # surfaces as ValueError/TypeError rather than a connection error.
            raise _not_an_address(address, e) from None
    cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=processes,
                           dashboard_address=None)
    return Client(cluster), cluster


def find_passes_dask(elements, stations, start: datetime, end: datetime,
                     min_el_deg: float | None = None, *, address: str | None = None,
                     chunk_sats: int = 1000, n_workers: int = 2, processes: bool = True,
                     connect_timeout_s: float = 10.0, **kwargs):
    """:func:`tracker.batch.find_passes_batch` on a Dask cluster.

    ``elements``: ElementSets (with ``line1``/``line2``) or ``(name, line1, line2)`` tuples.
    ``address``: a scheduler (``tcp://host:8786``); ``None`` starts a LocalCluster of
    ``n_workers`` single-threaded workers. Satellites go out in chunks of ``chunk_sats``.
    """
    from tracker.batch.finder import merge_tables, remap

    lines = _lines_of(elements)
    names = [n for n, _, _ in lines]
    if chunk_sats < 1:
        raise ConfigError(f"chunk_sats = {chunk_sats!r} is invalid; allowed: >= 1")
    client, cluster = _client(address, n_workers, processes, connect_timeout_s)
    try:
        futures = []
        bounds = list(range(0, len(lines), chunk_sats))
        for a in bounds:
            futures.append(client.submit(_run_chunk, lines[a:a + chunk_sats], list(stations),
                                         start, end, min_el_deg, dict(kwargs), pure=False))
        tables = client.gather(futures)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    parts = [remap(t, np.arange(a, min(a + chunk_sats, len(lines))), names, stations)
             for a, t in zip(bounds, tables, strict=True)]
    merged = merge_tables(parts, names, stations, parts[0].start if parts else start,
                          parts[0].end if parts else end)
    merged.stats["dask_chunks"] = len(parts)
    return merged


@dataclass(frozen=True)
class PartitionedResult:
    """What :func:`write_passes_dask` wrote: the folder and its part files (one per chunk, in
    satellite order), the number of passes, the satellites SGP4 could not propagate (indices
    into the ``elements`` given) and the finder's statistics summed over the chunks."""

    folder: Path
    files: list[Path]
    n_passes: int
    errors: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)


def _write_chunk(index: int, offset: int, lines, stations, start, end, min_el_deg, kwargs,
                 folder: Path, keep: tuple, rotator, meta: dict, rows: int):
    """On a worker: find the chunk's passes, keep those asked for, plan them (``rotator``)
    and write them as part ``index``; returns (passes, errors, stats), never the passes."""
    from tracker.batch.finder import SatError
    from tracker.export import error_records, pass_records

    table = select_passes(_run_chunk(lines, stations, start, end, min_el_deg, kwargs), *keep)
    plans = None
    if rotator is not None:
        from tracker.batch.summaries import plan_summaries

        satrecs = _satrecs(lines)
        plans = plan_summaries(table, dict(enumerate(satrecs)), rotator, keep[0])
    errors = [SatError(e.sat + offset, e.name, e.code, e.message, e.first_s)
              for e in table.errors]

    def groups():
        for a in range(0, max(len(table), 1), rows):
            part = slice(a, a + rows)
            yield pass_records(table.select(part), None if plans is None else plans[part])

    write_part(groups(), folder, index, meta, error_records(errors))
    return len(table), errors, table.stats


def _write_parts(client, folder: Path, force: bool, lines, chunk_sats: int, bounds, stations,
                 search: tuple, output: tuple, t0: float) -> list:
    """Submit every chunk, then write ``_common_metadata`` and put the folder in place; on
    any failure the temporary folder (and every part in it) is removed."""
    from tracker.export import error_records

    tmp = new_parts_folder(folder)
    futures: list = []
    try:
        futures = [client.submit(_write_chunk, k, a, lines[a:a + chunk_sats], stations,
                                 *search, tmp, *output, pure=False)
                   for k, a in enumerate(bounds)]
        results = client.gather(futures)
        errors = [e for _, chunk_errors, _ in results for e in chunk_errors]
        meta = dict(output[2], passes=sum(n for n, _, _ in results),
                    elapsed_s=round(time.perf_counter() - t0, 3))
        write_common_metadata(tmp, meta, error_records(errors))
        commit_parts_folder(tmp, folder, force)
    except BaseException as e:
        _settle(client, futures, wait_for_running=isinstance(e, Exception))
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return results


def _settle(client, futures: list, wait_for_running: bool) -> None:
    """Keep every chunk from writing into the temporary folder once it is removed. A running
    chunk cannot be stopped (it is a thread, or a task on another worker), so after an error
    every chunk is waited for (up to ``SETTLE_TIMEOUT_S``), else a part could land in a
    folder being deleted and keep it alive. On Ctrl-C the chunks are cancelled, not waited
    for."""
    if not futures:
        return
    from distributed import wait

    if wait_for_running:
        try:
            wait(futures, timeout=SETTLE_TIMEOUT_S)
            return
        except TimeoutError:
            pass
    client.cancel(futures)


def write_passes_dask(elements, stations, start: datetime, end: datetime, folder,
                      min_el_deg: float | None = None, *, min_max_el_deg: float = 0.0,
                      only: str | None = None, rotator=None, meta: dict | None = None,
                      force: bool = False, address: str | None = None,
                      chunk_sats: int = 1000, n_workers: int = 2, processes: bool = True,
                      connect_timeout_s: float = 10.0, rows_per_group: int = ROWS_PER_GROUP,
                      **kwargs) -> PartitionedResult:
    """:func:`find_passes_dask` with the passes written by the workers as a partitioned
    Parquet result in ``folder`` (one ``part-NNNNN.parquet`` per chunk of ``chunk_sats``
    satellites, plus ``_common_metadata``), never gathered into this process.

    The passes kept are those :func:`~tracker.batch.output.select_passes` keeps
    (``min_max_el_deg``, ``only``); ``rotator`` (a RotatorSpec) adds the planner's summary
    to each, as ``plan_summaries`` does. ``meta`` goes into every file's metadata with
    ``parts`` (the number of files); ``_common_metadata`` adds ``passes`` and ``elapsed_s`` and
    holds every chunk's errors. ``folder`` must not hold files unless ``force`` (and then only
    an earlier partitioned result), and must be reachable at the same path by every worker.
    Other arguments as for :func:`find_passes_dask`.
    """
    from tracker.export import require_pyarrow

    t0 = time.perf_counter()
    require_pyarrow()
    lines = _lines_of(elements)
    if chunk_sats < 1:
        raise ConfigError(f"chunk_sats = {chunk_sats!r} is invalid; allowed: >= 1")
    if rows_per_group < 1:
        raise ConfigError(f"rows_per_group = {rows_per_group!r} is invalid; allowed: >= 1")
    if not lines:
        raise ConfigError("no element sets given")
    check_only(only)
    keep = (float(min_max_el_deg), only)
    folder = check_output_dir(folder, force=force)
    bounds = list(range(0, len(lines), chunk_sats))
    meta = dict(meta or {}, parts=len(bounds))
    client, cluster = _client(address, n_workers, processes, connect_timeout_s,
                              "write_passes_dask")
    try:
        results = _write_parts(client, folder, force, lines, chunk_sats, bounds, list(stations),
                               (start, end, min_el_deg, dict(kwargs)),
                               (keep, rotator, meta, rows_per_group), t0)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    stats: dict = {"dask_chunks": len(bounds)}
    for _, _, chunk_stats in results:
        for k, val in chunk_stats.items():
            stats[k] = stats.get(k, 0) + val
    return PartitionedResult(folder, [folder / PART_NAME.format(k) for k in range(len(bounds))],
                             sum(n for n, _, _ in results),
                             [e for _, chunk_errors, _ in results for e in chunk_errors], stats)
