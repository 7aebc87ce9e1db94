"""What a station keeps on disk: the JSON-lines pass log and the small state file.

* :class:`PassLog` appends one JSON object per pass (planned vs measured max error, commands,
  motor starts, faults) and rotates by size with the standard library's
  :class:`~logging.handlers.RotatingFileHandler`, so a station left running for months keeps
  a bounded log. A write that fails (full disk, permissions) raises, so the service can say
  so instead of the log silently stopping.
* :class:`StationState` remembers the outcome of every recent pass, so a restarted service
  does not track a pass twice nor forget one it skipped. It is written atomically (a
  temporary file renamed over the old), so a crash or a full disk leaves the previous state
  whole; an unreadable state file is set aside (``.bad``) with a warning, never fatal.
"""

from __future__ import annotations

import json
import logging
import logging.handlers
import math
import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tracker.errors import ConfigError

STATE_VERSION = 1
# Outcomes older than this are dropped from the state file (the schedule never reaches back
# that far, so they can no longer be asked about).
STATE_KEEP_S = 3 * 86400.0
# A state file holds a few days of pass outcomes (kilobytes); a bigger one is not ours.
MAX_STATE_BYTES = 4_000_000


class _RaisingRotatingHandler(logging.handlers.RotatingFileHandler):
    """A rotating handler whose write errors reach the caller (logging's own default prints
    a traceback to stderr and carries on)."""

    def handleError(self, record: logging.LogRecord) -> None:
        raise  # logging calls this inside its except clause


class PassLog:
    """JSON lines, one per pass, rotated at ``max_bytes`` keeping ``backups`` old files
    (``passes.jsonl.1`` ...)."""

    def __init__(self, path: str | Path, *, max_bytes: int = 5_000_000, backups: int = 5):
        self.path = Path(path).expanduser()
        if self.path.exists() and not self.path.is_file():
            raise ConfigError(f"pass log {self.path} is not a regular file; give a file path")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            handler = _RaisingRotatingHandler(self.path, maxBytes=max_bytes,
                                              backupCount=backups, encoding="utf-8")
        except OSError as e:
            raise ConfigError(f"pass log {self.path}: cannot open it ({e.strerror}); choose a "
                              f"writable folder") from None
        handler.setFormatter(logging.Formatter("%(message)s"))
        self._handler = handler

    def write(self, record: Mapping[str, Any]) -> None:
        line = json.dumps(dict(record), sort_keys=True, allow_nan=False, default=str)
        self._handler.emit(logging.LogRecord("station", logging.INFO, "", 0, line, None, None))

    def close(self) -> None:
        self._handler.close()


@dataclass
class StationState:
    """The outcome of each recent pass by its schedule key: ``{"state", "reason",
    "los_s"}``."""

    passes: dict[str, dict[str, Any]] = field(default_factory=dict)

    @classmethod
    def load(cls, path: str | Path) -> tuple[StationState, str]:
        """The state at ``path`` (empty if none) and a warning ("" if none)."""
        path = Path(path).expanduser()
        if not path.exists():
            return cls(), ""
        try:
            if path.stat().st_size > MAX_STATE_BYTES:
                raise ValueError(f"larger than {MAX_STATE_BYTES:,} bytes")
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("version") != STATE_VERSION or not isinstance(data.get("passes"), dict):
                raise ValueError("not a station state file of this version")
            passes = {str(k): dict(v) for k, v in data["passes"].items() if _entry_ok(v)}
        except (OSError, ValueError, AttributeError) as e:
            bad = _free_name(path.with_name(path.name + ".bad"))
            try:
                os.replace(path, bad)
                where = f"; set aside as {bad}"
            except OSError:
                where = ""
            return cls(), f"state file {path} is unreadable ({e}){where}; starting afresh"
        return cls(passes), ""

    def note(self, key: str, state: str, reason: str, los_s: float) -> None:
        self.passes[key] = {"state": state, "reason": reason, "los_s": round(los_s, 1)}

    def prune(self, now_s: float) -> None:
        self.passes = {k: v for k, v in self.passes.items()
                       if float(v.get("los_s", now_s)) > now_s - STATE_KEEP_S}

    def save(self, path: str | Path) -> None:
        """Write atomically (the old file stays whole if this fails); raises ConfigError
        saying why when it cannot."""
        from tracker.files import write_atomic

        text = json.dumps({"version": STATE_VERSION, "passes": self.passes}, sort_keys=True,
                          indent=1)
        Path(path).expanduser().parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, text + "\n", force=True, label="state file")


@contextmanager
def state_lock(path: str | Path) -> Iterator[None]:
    """Hold ``FILE.lock`` beside the state file for a run: a second station run on the same
    state file (and so, most likely, the same rotator) is refused with a
    :class:`ConfigError` instead of both driving and overwriting each other's outcomes."""
    try:
        import fcntl
    except ImportError:        # pragma: no cover - Windows: no advisory locks, no check
        yield
        return
    lock = Path(path).expanduser().with_name(Path(path).name + ".lock")
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
        handle = open(lock, "a+", encoding="utf-8")
    except OSError as e:
        raise ConfigError(f"state file {path}: cannot open its lock {lock} ({e.strerror}); "
                          f"choose a writable folder") from None
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ConfigError(f"state file {path} is in use by another station run; stop "
                              f"that one first (two runs would drive one rotator)") from None
        yield
    finally:
        handle.close()


def _entry_ok(entry: Any) -> bool:
    """One pass outcome as :meth:`StationState.note` writes it (others are dropped)."""
    if not isinstance(entry, dict) or not isinstance(entry.get("state"), str):
        return False
    los_s = entry.get("los_s", 0.0)
    return (isinstance(los_s, (int, float)) and not isinstance(los_s, bool)
            and math.isfinite(los_s) and isinstance(entry.get("reason", ""), str))


def _free_name(path: Path) -> Path:
    """``path``, or ``path.1``, ``path.2`` ... the first that does not exist: a state file set
    aside never replaces one set aside before."""
    n = 0
    candidate = path
    while candidate.exists() or candidate.is_symlink():
        n += 1
        candidate = path.with_name(f"{path.name}.{n}")
    return candidate
