"""What leaves the batch finder: the passes a user keeps, and partitioned Parquet output.

:func:`select_passes` applies the filters of ``tracker batch`` (a minimum maximum elevation,
sunlit or visible passes only). A *partitioned* result is a folder of Parquet files, one per
satellite chunk (``part-00000.parquet``, ...), each written where the chunk was computed (a
Dask worker), plus ``_common_metadata`` (the schema and the whole run's metadata). pyarrow
reads the folder as one dataset (``pyarrow.dataset.dataset(folder)`` or
``pyarrow.parquet.read_table(folder)``; names starting with ``_`` or ``.`` are skipped).

The folder is built under a temporary name beside it and renamed into place when every part
is written: a failed run leaves no partial folder and an existing one untouched.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from tracker.errors import ConfigError, OutputExistsError, with_advice

PART_NAME = "part-{:05d}.parquet"
COMMON_METADATA = "_common_metadata"
_OURS = re.compile(r"^(part-\d{5}\.parquet|_common_metadata)$")
ONLY = ("sunlit", "visible")


def check_only(only: str | None) -> None:
    if only not in (None, *ONLY):
        raise ConfigError(f"only = {only!r} is invalid; allowed: None, 'sunlit', 'visible'")


def select_passes(table, min_max_el_deg: float = 0.0, only: str | None = None):
    """The passes of ``table`` whose maximum elevation reaches ``min_max_el_deg``, and with
    ``only="sunlit"`` / ``"visible"`` only the sunlit / visible ones."""
    check_only(only)
    keep = table.passes["max_el_deg"] >= min_max_el_deg
    if only is not None:
        keep &= table.passes[only]
    # Keeping every pass (the usual case) is a view: no copy of a large table.
    return table.select(slice(None) if keep.all() else keep)


def check_output_dir(path: str | Path, *, force: bool = False, label: str = "") -> Path:
    """Refuse, before any work, a folder a partitioned result cannot be written to: one that
    is a file, whose parent does not exist, or that holds files already (unless ``force``, and
    then only the files of an earlier partitioned result: anything else is never deleted)."""
    folder = Path(path).expanduser()
    where = f"{label} {path}" if label else str(path)
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"{where} is not a folder; a partitioned result is a folder of "
                          "Parquet files")
    if not folder.exists():
        if not folder.parent.is_dir():
            raise ConfigError(f"{where}: folder {folder.parent} does not exist; create it or "
                              "choose another path")
        return folder
    present = sorted(p.name for p in folder.iterdir())
    if present and not force:
        raise with_advice(OutputExistsError,
                          f"{where} already exists and is not empty; not writing into it",
                          " (pass force=True to replace it, or choose another folder)")
    foreign = [name for name in present if not _OURS.match(name)]
    if foreign:
        shown = ", ".join(foreign[:3]) + (" ..." if len(foreign) > 3 else "")
        raise ConfigError(f"{where} holds files that are not a partitioned pass result "
                          f"({shown}); not replacing it: choose an empty or new folder")
    return folder


def new_parts_folder(folder: Path) -> Path:
    """A fresh temporary folder beside ``folder`` for the parts (same file system, so the
    finished result is renamed into place), readable as a plain ``mkdir`` would make it."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", suffix=".tmp", dir=folder.parent))
    umask = os.umask(0o022)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    return tmp


def commit_parts_folder(tmp: Path, folder: Path, force: bool) -> None:
    """Put the finished folder ``tmp`` in the place of ``folder`` (checked again: it may have
    changed during the run)."""
    check_output_dir(folder, force=force)
    if folder.exists() and any(folder.iterdir()):
        old = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", suffix=".old",
                                    dir=folder.parent))
        os.replace(folder, old)
        os.replace(tmp, folder)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, folder)  # a missing or empty folder is replaced directly


def write_part(records: Iterator, folder: Path, index: int, meta: dict,
               errors: list[dict]) -> Path:
    """Write one part (``records``: PassRecords in row groups) as ``part-NNNNN.parquet``."""
    from tracker.export import write_parquet
    from tracker.files import write_atomic

    path = folder / PART_NAME.format(index)
    write_atomic(path, lambda f: write_parquet(records, f, meta=meta, errors=errors))
    return path


def write_common_metadata(folder: Path, meta: dict, errors: list[dict]) -> None:
    """``_common_metadata``: the schema with the whole run's ``{"schema", "meta", "errors"}``."""
    import pyarrow.parquet as pq

    from tracker.export import arrow_schema, require_pyarrow

    pq.write_metadata(arrow_schema(require_pyarrow(), meta, errors), folder / COMMON_METADATA)
