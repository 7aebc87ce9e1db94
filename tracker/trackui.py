"""What the live tracker shows and records.

* :class:`RichPanel` — a live panel on a terminal (rich): target az/el, commanded and actual
  antenna position, pointing error, mode, AOS/LOS countdown, a progress bar, the next pass.
* :class:`PlainLines` — timestamped lines for logs and pipes (no TTY): every state change and
  command, and a status line every ``every_s`` seconds of (possibly simulated) time.
* :class:`JsonLinesLog` — ``--log FILE``: one JSON object per command, reply and state change,
  with UTC timestamps, flushed line by line so an interrupted run keeps its log.

All three take the same two calls from :func:`tracker.stream.run_pass`: ``event(kind, **data)``
and ``status(Status)``.
"""

from __future__ import annotations

import json
import math
import os
import sys
import threading
from typing import IO, Any

from tracker.clock import Clock
from tracker.errors import ConfigError
from tracker.stream import Phase, Status
from tracker.timescale import iso_utc, utc_strftime


def _mmss(seconds: float) -> str:
    seconds = max(0.0, seconds)
    m, s = divmod(round(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def countdown(st: Status) -> str:
    """"AOS in 1:23" / "LOS in 4:56" / "pass over"."""
    if st.t_s < st.aos_s:
        return f"AOS in {_mmss(st.aos_s - st.t_s)}"
    if st.t_s <= st.los_s:
        return f"LOS in {_mmss(st.los_s - st.t_s)}"
    return "pass over"


def _deg(v: float | None, width: int = 5) -> str:
    return "-".rjust(width) if v is None or not math.isfinite(v) else f"{v:{width}.1f}"


class JsonLinesLog:
    """Append one JSON object per event to ``path``.

    The log serves the pass, never the other way round: a path that cannot be opened is a
    :class:`~tracker.errors.ConfigError` before anything moves, and a write that fails later
    (full disk, a file size limit, ``/dev/full``) warns once on ``warn_stream`` and the log
    stops while tracking goes on. Lines go out whole with one ``os.write`` each, so a failed
    write leaves no buffered half line behind to fail again at close.
    """

    def __init__(self, path, clock: Clock, warn_stream: IO[str] | None = None):
        self.clock = clock
        self.path = str(path)
        self._warn = warn_stream if warn_stream is not None else sys.stderr
        self._fd: int | None = open_log_fd(self.path)

    def event(self, kind: str, **data: Any) -> None:
        if self._fd is None:
            return
        t = self.clock.timestamp()
        rec = {"t": iso_utc(t, timespec="milliseconds"), "t_s": round(t, 3), "kind": kind}
        rec.update({k: v for k, v in data.items() if v is not None})
        line = (json.dumps(rec, default=str) + "\n").encode("utf-8")
        written = 0
        try:
            while written < len(line):
                written += os.write(self._fd, line[written:])
        except OSError as e:
            if written:
                self._cut_partial_line(written)
            self._give_up(e)

    def _cut_partial_line(self, written: int) -> None:
        """Leave only whole lines: a reader must be able to parse every one."""
        try:
            os.ftruncate(self._fd, os.lseek(self._fd, 0, os.SEEK_CUR) - written)
        except OSError:
            pass   # not a regular file (a device, a pipe): nothing to cut

    def _give_up(self, e: OSError) -> None:
        self._warn.write(f"tracker: warning: cannot write the log {self.path} "
                         f"({e.strerror or e}); tracking goes on without it\n")
        self._warn.flush()
        self.close()

    def status(self, st: Status) -> None:
        return None   # replies and commands already carry the story

    def close(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            try:
                os.close(fd)
            except OSError:
                pass   # nothing left to save: every line was written (or warned about)


def open_log_fd(path: str) -> int:
    """Open ``path`` for appending (created if missing); a clear ConfigError when it cannot
    be. Non-blocking open: a FIFO nobody reads is refused instead of hanging the run."""
    flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, flags, 0o644)
    except IsADirectoryError:
        raise ConfigError(f"log file {path} is a directory; give a file name, e.g. "
                          f"{os.path.join(path, 'track.jsonl')}") from None
    except FileNotFoundError:
        raise ConfigError(f"log file {path}: folder {os.path.dirname(path) or '.'} does not "
                          f"exist; create it or choose another path") from None
    except PermissionError:
        raise ConfigError(f"log file {path}: permission denied; choose a path you can write "
                          f"to") from None
    except OSError as e:
        raise ConfigError(f"log file {path}: cannot open it for writing "
                          f"({e.strerror or e})") from None
    if hasattr(os, "set_blocking"):
        os.set_blocking(fd, True)
    return fd


class PlainLines:
    """Timestamped lines on ``stream`` (simulated time when the clock is simulated)."""

    def __init__(self, clock: Clock, stream: IO[str] | None = None, every_s: float = 10.0):
        self.clock = clock
        self.stream = stream or sys.stdout
        self.every_s = every_s
        self._last_status = -math.inf

    def _line(self, text: str) -> None:
        self.stream.write(f"{utc_strftime(self.clock.timestamp(), '%H:%M:%S')}  {text}\n")
        self.stream.flush()

    def event(self, kind: str, **data: Any) -> None:
        if kind == "reply":
            return   # one per cycle: too many for a terminal; the JSON log keeps them
        if kind == "command":
            if data.get("cmd") == "stop":
                self._line("command  all-stop")
            else:
                el = data.get("el")
                el_s = "" if el is None else f" el {el + 0.0:5.1f}"
                extra = f"  ({data['clamped']})" if data.get("clamped") else ""
                self._line(f"command  {data.get('reason', ''):<11} az {data['az']:5.1f}{el_s}"
                           f"{extra}")
            return
        if kind == "state":
            state = data.get("state")
            if state == "phase":
                self._line(f"phase    {data.get('phase')}")
            else:
                note = data.get("note") or data.get("reason") or ""
                self._line(f"state    {state}{'  ' + note if note else ''}")
            return
        if kind == "info":
            self._line(str(data.get("text", "")))

    def status(self, st: Status) -> None:
        if st.t_s - self._last_status < self.every_s and st.phase is not Phase.DONE:
            return
        self._last_status = st.t_s
        self._line(f"{st.phase.value:<11} target az {st.target_az_deg:5.1f} el "
                   f"{st.target_el_deg:5.1f}  antenna az {_deg(st.antenna_bearing_deg)} el "
                   f"{_deg(st.antenna_el_deg)}  error {_deg(st.error_deg, 4)}  "
                   f"{countdown(st)}  cmds {st.commands}")

    def close(self) -> None:
        return None


class RichPanel:
    """A live panel on a terminal; falls back to nothing if rich cannot draw."""

    def __init__(self, clock: Clock, title: str, banner: str = "", next_pass: str = ""):
        from rich.console import Console
        from rich.live import Live

        self.clock = clock
        self.title = title
        self.banner = banner
        self.next_pass = next_pass
        self.console = Console()
        self._events: list[str] = []
        self._st: Status | None = None
        self._live = Live(self._render(), console=self.console, refresh_per_second=8,
                          transient=False)
        self._live.start()

    def _render(self):
        from rich.panel import Panel
        from rich.progress_bar import ProgressBar
        from rich.table import Table

        grid = Table.grid(padding=(0, 2))
        grid.add_column(justify="right", style="bold")
        grid.add_column()
        st = self._st
        if self.banner:
            grid.add_row("", f"[yellow]{self.banner}[/]")
        if st is None:
            grid.add_row("status", "connecting...")
        else:
            grid.add_row("time", f"{utc_strftime(st.t_s, '%H:%M:%S')} UTC   {countdown(st)}")
            grid.add_row("phase / mode", f"{st.phase.value} / {st.mode}")
            grid.add_row("target", f"az {st.target_az_deg:6.1f}   el {st.target_el_deg:6.1f}")
            cmd = ("-" if st.command_az_m_deg is None else
                   f"az {st.command_az_m_deg:6.1f}   el {_deg(st.command_el_deg, 6)}"
                   f"   (mechanical)")
            grid.add_row("commanded", cmd)
            grid.add_row("antenna", f"az {_deg(st.antenna_bearing_deg, 6)}   el "
                         f"{_deg(st.antenna_el_deg, 6)}   (mech az "
                         f"{_deg(st.antenna_az_m_deg, 5)})")
            err = st.error_deg
            style = "green" if err is not None and err <= 5 else "red"
            grid.add_row("error", f"[{style}]{_deg(err, 5)} deg[/]   commands {st.commands}")
            bar = ProgressBar(total=1.0, completed=st.progress, width=40)
            grid.add_row("pass", bar)
            if st.note:
                grid.add_row("note", f"[red]{st.note}[/]")
        if self.next_pass:
            grid.add_row("next pass", self.next_pass)
        for line in self._events[-4:]:
            grid.add_row("", f"[dim]{line}[/]")
        return Panel(grid, title=self.title, border_style="cyan")

    def event(self, kind: str, **data: Any) -> None:
        if kind == "reply":
            return
        if kind == "command":
            text = ("all-stop" if data.get("cmd") == "stop" else
                    f"{data.get('reason')}: W az {data.get('az'):.0f} el {data.get('el')}")
        elif kind == "state":
            text = (f"phase {data.get('phase')}" if data.get("state") == "phase"
                    else f"{data.get('state')} {data.get('note') or ''}".strip())
        else:
            text = str(data.get("text", ""))
        self._events.append(f"{utc_strftime(self.clock.timestamp(), '%H:%M:%S')} {text}")
        self._live.update(self._render())

    def status(self, st: Status) -> None:
        self._st = st
        self._live.update(self._render())

    def close(self) -> None:
        self._live.stop()


class Fanout:
    """Send every call to several UIs/logs."""

    def __init__(self, *sinks):
        self.sinks = [s for s in sinks if s is not None]

    def event(self, kind: str, **data: Any) -> None:
        for s in self.sinks:
            s.event(kind, **data)

    def status(self, st: Status) -> None:
        for s in self.sinks:
            s.status(st)

    def close(self) -> None:
        for s in self.sinks:
            s.close()


class PrefixedLines:
    """Plain timestamped lines of one antenna: ``02:07:10  ant1 ISS (ZARYA)  command ...``."""

    def __init__(self, clock: Clock, prefix: str):
        self.prefix = prefix
        self.lines = PlainLines(clock, stream=self)

    def write(self, text: str) -> None:
        # PlainLines writes "HH:MM:SS  text\n" in one call: put the antenna after the time.
        hms, sep, rest = text.partition("  ")
        sys.stdout.write(f"{hms}{sep}{self.prefix}  {rest}" if sep else text)

    def flush(self) -> None:
        sys.stdout.flush()


class AntennaOut:
    """One antenna's sinks of a two-antenna run: its prefixed plain lines and the shared JSON
    log (records carry ``antenna``); one lock, so the two loops' lines never interleave."""

    def __init__(self, n: int, prefix: str, clock: Clock, log: JsonLinesLog | None,
                 lock: threading.Lock):
        self.n, self.log, self.lock = n, log, lock
        self.lines = PrefixedLines(clock, prefix).lines

    def event(self, kind: str, **data: Any) -> None:
        with self.lock:
            self.lines.event(kind, **data)
            if self.log is not None:
                self.log.event(kind, antenna=self.n, **data)

    def status(self, st: Status) -> None:
        with self.lock:
            self.lines.status(st)

    def close(self) -> None:
        return None
