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


# What each phase and loop state is called on screen (the JSON log keeps the machine names).
PHASE_WORDS = {"wait": "waiting for the pass", "preposition": "moving to the AOS point",
               "track": "tracking", "park": "parking", "done": "pass over"}
_STATE_WORDS = {"connected": "connected", "finished": "pass finished",
                "stopped": "stopped", "contradiction": "read-back disagrees",
                "controller_off": "controller reports no position", "no_reply": "no reply",
                "port_lost": "port lost", "reconnecting": "reconnecting",
                "reconnected": "reconnected", "reconnect_failed": "reconnect failed",
                "stall": "stall", "readback_inconsistent": "read-back inconsistent",
                "stop_failed": "all-stop failed"}
# Said by an info line of their own, or only for the log.
_STATES_UNSAID = {"start", "plan", "pass_done"}


def describe_state(data: dict) -> str | None:
    """A ``state`` event in words ("" parts dropped); None for one the log alone keeps."""
    state = str(data.get("state"))
    if state == "phase":
        return PHASE_WORDS.get(str(data.get("phase")), str(data.get("phase")))
    if state in _STATES_UNSAID:
        return None
    words = _STATE_WORDS.get(state, state.replace("_", " "))
    note = data.get("note") or data.get("reason") or ""
    if state == "reconnecting" and data.get("wait_s") is not None:
        note = f"in {data['wait_s']:g} s"
    return f"{words}: {note}" if note else words


def describe_command(data: dict) -> str:
    """A ``command`` event in words: the bearing, and the mechanical azimuth where it
    differs (overlap, a south stop)."""
    if data.get("cmd") == "stop":
        return "all-stop"
    az = data.get("bearing", data.get("az"))
    az_m = data.get("az_m")
    mech = f" (mech {az_m:.0f})" if az_m is not None and abs(az_m - az) > 0.05 else ""
    el = data.get("el")
    el_s = "" if el is None else f" el {el + 0.0:5.1f}"
    extra = f"  ({data['clamped']})" if data.get("clamped") else ""
    return f"{data.get('reason', ''):<11} az {az:5.1f}{el_s}{mech}{extra}"


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
            self._line(f"command  {describe_command(data)}")
            return
        if kind == "state":
            text = describe_state(data)
            if text is not None:
                self._line(text)
            return
        if kind == "info":
            self._line(str(data.get("text", "")))

    def status(self, st: Status) -> None:
        if st.t_s - self._last_status < self.every_s and st.phase is not Phase.DONE:
            return
        self._last_status = st.t_s
        ant_el = "" if st.antenna_el_deg is None else f" el {_deg(st.antenna_el_deg)}"
        self._line(f"{st.phase.value:<11} target az {st.target_az_deg:5.1f} el "
                   f"{st.target_el_deg:5.1f}  antenna az {_deg(st.antenna_bearing_deg)}"
                   f"{ant_el}  error {_deg(st.error_deg, 4)}  "
                   f"{countdown(st)}  cmds {st.commands}")

    def close(self) -> None:
        return None


class RichPanel:
    """A live panel on a terminal; falls back to nothing if rich cannot draw.

    Its height stays fixed while a pass runs: a header that does not change (``banner``:
    what runs, e.g. SIMULATION; ``header``: notes such as the replayed date and the element
    age), the date and time, the pointing, the plan of the pass and its result (both kept
    after the run), and the last :attr:`EVENT_ROWS` events, each cut to one line.
    ``console``: where to draw (a recording Console in tests)."""

    EVENT_ROWS = 4

    def __init__(self, clock: Clock, title: str, banner: str = "", next_pass: str = "",
                 header: tuple[str, ...] = (), console: Any = None):
        from rich.console import Console
        from rich.live import Live

        self.clock = clock
        self.title = title
        self.banner = banner
        self.header = tuple(header)
        self.next_pass = next_pass
        self.console = console if console is not None else Console()
        self._events: list[str] = []
        self._st: Status | None = None
        self._connected = ""        # what the panel says before the first status
        self._plan = ""
        self._result: list[str] = []
        # Rendered afresh at every refresh (the clock ticks while nothing else changes);
        # output of other code would tear the panel, so none is redirected into it.
        self._live = Live(console=self.console, get_renderable=self._render,
                          refresh_per_second=8, transient=False, redirect_stdout=False,
                          redirect_stderr=False)
        self._restore_echo = _quiet_keyboard() if console is None else None
        self._live.start()

    def _render(self):
        """The panel with as many event rows as the terminal's height leaves room for: a
        panel taller than the terminal cannot be redrawn in place (its top would be drawn
        again on every redraw and at the end)."""
        room = self.console.size.height - 1
        for rows in range(self.EVENT_ROWS, -1, -1):
            panel = self._panel(rows)
            if rows == 0 or len(self.console.render_lines(panel, pad=False)) <= room:
                return panel
        return panel

    def _panel(self, event_rows: int):
        from rich.panel import Panel
        from rich.table import Table
        from rich.text import Text

        grid = Table.grid(padding=(0, 2))
        grid.add_column(justify="right", style="bold", no_wrap=True)
        grid.add_column()
        if self.banner:
            grid.add_row("", f"[yellow]{self.banner}[/]")
        for line in self.header:
            grid.add_row("", f"[yellow]{line}[/]")
        self._pointing_rows(grid)
        if self._plan:
            grid.add_row("plan", self._plan)
        for i, line in enumerate(self._result):
            grid.add_row("result" if i == 0 else "", line)
        if self.next_pass:
            grid.add_row("next pass", self.next_pass)
        shown = self._events[-event_rows:] if event_rows else []
        for line in shown + [""] * (event_rows - len(shown)):
            grid.add_row("", Text(line, style="dim", no_wrap=True, overflow="ellipsis"))
        return Panel(grid, title=self.title, border_style="cyan")

    def _pointing_rows(self, grid) -> None:
        from rich.progress_bar import ProgressBar

        st = self._st
        if st is None:
            now = utc_strftime(self.clock.timestamp(), '%Y-%m-%d %H:%M:%S')
            grid.add_row("time", f"{now} UTC")
            grid.add_row("status", self._connected or "connecting...")
            return
        grid.add_row("time", f"{utc_strftime(st.t_s, '%Y-%m-%d %H:%M:%S')} UTC   "
                             f"{countdown(st)}")
        grid.add_row("phase / mode", f"{PHASE_WORDS.get(st.phase.value, st.phase.value)} / "
                                     f"{st.mode}")
        grid.add_row("target", f"az {st.target_az_deg:6.1f}   el {st.target_el_deg:6.1f}")
        grid.add_row("commanded", self._commanded(st))
        ant_el = "" if st.antenna_el_deg is None else f"   el {_deg(st.antenna_el_deg, 6)}"
        grid.add_row("antenna", f"az {_deg(st.antenna_bearing_deg, 6)}{ant_el}"
                                f"{self._mech(st.antenna_bearing_deg, st.antenna_az_m_deg)}")
        err = st.error_deg
        style = "green" if err is not None and err <= 5 else "red"
        grid.add_row("error", f"[{style}]{_deg(err, 5)} deg[/]   commands {st.commands}")
        grid.add_row("pass", ProgressBar(total=1.0, completed=st.progress, width=40))
        grid.add_row("note", f"[red]{st.note}[/]" if st.note else "")

    def _commanded(self, st: Status) -> str:
        if st.command_az_m_deg is None:
            return "-"
        bearing = (st.command_az_m_deg + self._stop_bearing(st)) % 360.0
        el = "" if st.command_el_deg is None else f"   el {_deg(st.command_el_deg, 6)}"
        return f"az {bearing:6.1f}{el}{self._mech(bearing, st.command_az_m_deg)}"

    @staticmethod
    def _stop_bearing(st: Status) -> float:
        """The rotator's stop bearing, from the antenna's two azimuths (0 when unknown)."""
        if st.antenna_bearing_deg is None or st.antenna_az_m_deg is None:
            return 0.0
        return round(st.antenna_bearing_deg - st.antenna_az_m_deg) % 360.0

    @staticmethod
    def _mech(bearing: float | None, az_m: float | None) -> str:
        """The mechanical azimuth, only where it differs from the bearing."""
        if bearing is None or az_m is None or abs(bearing - az_m) <= 0.05:
            return ""
        return f"   (mechanical {az_m:.0f})"

    def event(self, kind: str, **data: Any) -> None:
        if kind == "reply":
            return
        if kind == "command":
            text: str | None = describe_command(data)
        elif kind == "state":
            if data.get("state") == "connected":
                self._connected = "connected, planning the pass..."
            elif data.get("state") == "plan":
                self._connected = "waiting for the pass"
            text = describe_state(data)
        else:
            text = str(data.get("text", ""))
            topic = data.get("topic")
            if topic == "plan":
                self._plan, self._result = text, []
            elif topic in ("result", "cause"):
                self._result.append(text)
        if text is not None:
            self._events.append(f"{utc_strftime(self.clock.timestamp(), '%H:%M:%S')} {text}")

    def status(self, st: Status) -> None:
        self._st = st

    def close(self) -> None:
        try:
            self._live.stop()
        finally:
            if self._restore_echo is not None:
                self._restore_echo()


def _quiet_keyboard():
    """Stop the terminal echoing keys (``^C`` above all) while the panel is drawn; returns
    what puts the echo back, or None. The panel's last line fills the terminal's width, so
    an echoed ``^C`` wraps to a new line, and the panel's next redraw, counting its lines
    up from there, leaves its old top border on screen: drawn twice. Ctrl-C still stops the
    run: only the echo goes, not the signal."""
    try:
        import termios
    except ImportError:     # not a POSIX terminal: nothing to quiet
        return None
    try:
        fd = sys.stdin.fileno()
        if not os.isatty(fd):
            return None
        before = termios.tcgetattr(fd)
        quiet = list(before)
        quiet[3] &= ~(termios.ECHO | getattr(termios, "ECHOCTL", 0))
        termios.tcsetattr(fd, termios.TCSANOW, quiet)
    except (OSError, ValueError, termios.error):
        return None

    def restore() -> None:
        try:
            termios.tcsetattr(fd, termios.TCSANOW, before)
        except (OSError, termios.error):
            pass    # the terminal is gone; nothing to restore

    return restore


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
