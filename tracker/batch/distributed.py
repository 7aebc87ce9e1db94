"""Dask backend: the batch job split into satellite chunks on a dask.distributed cluster.

Satellites are independent in the finder, so each chunk runs the ordinary local finder on a
worker and the tables are re-indexed and merged: the result is identical to the local path.
Elements travel as TLE lines (sgp4's ``Satrec`` cannot be pickled) and are parsed on the
worker. dask is an optional dependency (extra ``dask``).
"""

from __future__ import annotations

from datetime import datetime

import numpy as np

from tracker.errors import ConfigError


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
    from sgp4.api import Satrec

    from tracker.batch.finder import find_passes_batch

    satrecs = [Satrec.twoline2rv(a, b) for _, a, b in lines]
    return find_passes_batch(satrecs, [n for n, _, _ in lines], stations, start, end,
                             min_el_deg, **kwargs)


def _client(address: str | None, n_workers: int, processes: bool, timeout_s: float):
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError("find_passes_dask needs dask.distributed: pip install "
                          "'rotator-tracker[dask]'") from None
    if address:
        try:
            return Client(address, timeout=f"{timeout_s}s"), None
        except OSError as e:
            raise ConfigError(f"cannot reach the Dask scheduler at {address}: {e}") from None
        except (ValueError, TypeError) as e:
            # distributed parses the address itself; a typo (bad port, unknown scheme)
            # surfaces as ValueError/TypeError rather than a connection error.
            raise ConfigError(f"address {address}: not a scheduler address ({e}); give "
                              f"e.g. tcp://host:8786, or no address for a local "
                              f"cluster") from None
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
