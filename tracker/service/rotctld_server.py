"""A Hamlib-compatible control port: a ``rotctld`` protocol TCP server in front of any of the
tool's controllers, guarded by its limits, horizon mask and stall watch.

Clients (gpredict, ``rotctl -m 2 -r HOST:PORT``, the tool's own rotctld driver) speak
rotctld's line protocol (``docs/station.md``, "Control port"). Every command runs on the one
driver under one lock, so several clients at once are serialised.

Frame: the server speaks the controller's *wire degrees* (:mod:`tracker.mount`,
``MountFrame``): the scale Hamlib's own backend for that controller would show, so a client
set up for ``rotctld -m 603`` on the same box needs no change. ``\\dump_state`` reports
``min_az=0`` and ``max_az`` the top of the effective wire scale (450 for a G-5500 on a
GS-232B in 450 deg mode, 360 for a controller that takes bearings). The board, which shows
true bearings, is converted with :meth:`_bearing_of_wire` / :meth:`_wire_of_bearing`, the
one place the server converts (through ``spec.frame``).

Ownership: ``"outside"`` (:meth:`RotctldServer.hand_over`: clients may drive, the driver is
opened on the first command that needs it) or ``"station"`` (:meth:`RotctldServer.take_back`:
outside moves are stopped, the driver is closed, moves are answered ``RPRT -9``, Hamlib's
"Command rejected by the rig", and positions come from the board). A new server belongs to
the station until it is handed over; standalone use hands it over for good.
"""

from __future__ import annotations

import math
import re
import socket
import socketserver
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from tracker.clock import Clock
from tracker.errors import (
    LimitError,
    ProtocolError,
    RotatorIOError,
    RotatorTimeout,
    TrackerError,
)
from tracker.geometry import boresight_horizon_ok, move_clears_mask
from tracker.mount import MotorModel, RotatorSpec
from tracker.planner import park_position
from tracker.protocols.base import RotatorDriver
from tracker.session import EffectiveLimits
from tracker.stall import AxisWatch, stall_error
from tracker.station import Station
from tracker.stream import StreamSettings

# Hamlib rig.h enum rig_errcode_e; the texts are tracker.protocols.rotctld.HAMLIB_ERRORS.
RIG_EINVAL = 1       # invalid parameter: outside the limits, below the mask, not a number
RIG_ENIMPL = 4       # feature not implemented: a command this server does not know
RIG_ETIMEOUT = 5     # the controller did not answer
RIG_EIO = 6          # the controller's port failed (or could not be opened)
RIG_EPROTO = 8       # the controller answered something unreadable
# The station holds the rotator: the command is refused by the "rig" (the server in front of
# it), and a client can try again later. Hamlib 4.5 has no "busy" code; -14 (bus collision)
# is a CI-V bus fault and -19 (security) means a permission the client could get.
RIG_ERJCTED = 9
RIG_ENAVAIL = 11     # feature not available: continuous moves (M) cannot be guarded

ROT_MODEL_NETROTCTL = 2   # what dump_state names as the model: Hamlib's network rotator
DUMP_STATE_VERSION = 1    # the key=value dump_state Hamlib 4.x rotctld sends
POLL_S = 0.25             # how often a move under the stall watch is read back
# The longest request is a few dozen bytes; a longer line is refused and the client closed,
# so a client that never sends a newline cannot grow the server's memory.
MAX_LINE_BYTES = 1024
# A plain decimal: Python's float() would also take "1_0" (as 10), "inf" and "nan".
_DECIMAL_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")

EventSink = Callable[..., None]


def _no_events(kind: str, **data: Any) -> None:
    return None


class Refused(Exception):
    """A command answered ``RPRT -code``; ``text`` is the one-line event, if any."""

    def __init__(self, code: int, text: str = ""):
        super().__init__(text)
        self.code = code
        self.text = text


@dataclass
class _Watched:
    """A move under the stall watch: the target in wire degrees and one watch per axis."""

    wire_az_deg: float
    el_deg: float | None
    belief_m_deg: float
    watches: dict[str, AxisWatch] = field(default_factory=dict)


@dataclass
class Reply:
    """What one command answers: data lines (before ``RPRT``) and the code (0 or Hamlib's
    positive error number); ``rprt`` False for a query that answers data alone."""

    lines: list[str]
    code: int = 0
    rprt: bool = True


# Command names: short letter -> (long name, how many arguments, extended labels of the data)
COMMANDS: dict[str, tuple[str, int, tuple[str, ...]]] = {
    "p": ("get_pos", 0, ("Azimuth", "Elevation")),
    "P": ("set_pos", 2, ()),
    "S": ("stop", 0, ()),
    "K": ("park", 0, ()),
    "_": ("get_info", 0, ("Info",)),
    "M": ("move", 2, ()),
    "\x8f": ("dump_state", 0, ()),
    "\x01": ("dump_caps", 0, ()),
}
LONG_NAMES = {long: short for short, (long, _n, _l) in COMMANDS.items()}


def _degrees(text: str) -> float | None:
    """The number in one argument of a move, or None when it is not a finite plain decimal."""
    if _DECIMAL_RE.fullmatch(text) is None:
        return None
    value = float(text)
    return value if math.isfinite(value) else None


def parse_line(line: str) -> tuple[str | None, str, list[str]]:
    """``(separator or None, short command, arguments)`` of one request line. The separator is
    rotctld's extended-response prefix: ``+`` (newline), ``;``, ``|`` or ``,``; the command
    is a letter or a ``\\long_name`` (``\\set_pos 10 20``)."""
    text = line.strip()
    sep = None
    if text[:1] in ("+", ";", "|", ","):
        sep = "\n" if text[0] == "+" else text[0]
        text = text[1:].lstrip()
    if text.startswith("\\"):
        name, *args = text[1:].split() or [""]
        return sep, LONG_NAMES.get(name, "\\" + name), args
    return sep, text[:1], text[1:].split()


class RotctldServer:
    """A rotctld-protocol TCP server driving one controller (see the module docstring).

    ``connect()`` opens the driver (wire degrees, the scale of ``driver_limits(spec)``);
    ``station`` gives the horizon mask and minimum elevation every move is checked against;
    ``board`` (optional) is kept up to date with the control port and the antenna;
    ``events(kind, text=...)`` hears one line per refusal, stall, hand-over and error.
    """

    def __init__(self, connect: Callable[[], RotatorDriver], spec: RotatorSpec, *,
                 station: Station | None = None, clock: Clock, host: str = "127.0.0.1",
                 port: int = 4533, board: Any = None, events: EventSink | None = None,
                 settings: StreamSettings | None = None, poll_s: float = POLL_S):
        self.connect = connect
        self.spec = spec
        self.station = station
        self.clock = clock
        self.board = board
        self.events = events or _no_events
        self.settings = settings or StreamSettings()
        self.poll_s = float(poll_s)
        self._bind = (host, int(port))
        self._lock = threading.RLock()          # the driver and the state below
        self._driver: RotatorDriver | None = None
        self._limits: EffectiveLimits | None = None
        self._owner = "station"
        self._pending = False                   # a move was sent and not known finished
        self._watched: _Watched | None = None
        self._clients = 0
        self._closed = threading.Event()
        self._server: socketserver.ThreadingTCPServer | None = None
        self._threads: list[threading.Thread] = []
        self._sockets: set[socket.socket] = set()

    # Life cycle ------------------------------------------------------------------------------

    @property
    def address(self) -> tuple[str, int]:
        if self._server is None:
            return self._bind
        host, port = self._server.server_address[:2]
        return str(host), int(port)

    @property
    def listen(self) -> str:
        """``host:port`` the server listens on."""
        host, port = self.address
        return f"{host}:{port}"

    @property
    def owner(self) -> str:
        return self._owner

    @property
    def clients(self) -> int:
        return self._clients

    def start(self) -> RotctldServer:
        """Listen and serve in background threads (port 0: a free port, see :attr:`address`)."""
        server = self

        class Handler(socketserver.StreamRequestHandler):
            def handle(self) -> None:
                with server._lock:
                    server._sockets.add(self.connection)
                try:
                    server._serve_client(self.rfile, self.wfile)
                finally:
                    with server._lock:
                        server._sockets.discard(self.connection)

        class Server(socketserver.ThreadingTCPServer):
            allow_reuse_address = True
            daemon_threads = True
            address_family = socket.AF_INET6 if ":" in self._bind[0] else socket.AF_INET

        try:
            self._server = Server(self._bind, Handler)
        except OSError as e:
            from tracker.errors import ConfigError
            raise ConfigError(f"cannot listen on {self._bind[0]}:{self._bind[1]}: "
                              f"{e.strerror or e}") from None
        for target in (self._server.serve_forever, self._watch_loop):
            t = threading.Thread(target=target, daemon=True, name="rotctld-server")
            t.start()
            self._threads.append(t)
        self._publish()
        return self

    def _stop_serving(self) -> None:
        """No new clients, no more commands: the listener and every client socket close."""
        if self._closed.is_set():
            return
        self._closed.set()
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
        with self._lock:
            for sock in self._sockets:
                try:
                    sock.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def all_stop(self) -> bool:
        """Stop serving, then send all-stop (opening the port if needed) while the outside
        holds the rotator: the last bytes on the wire. The session's ``all_stop``."""
        self._stop_serving()
        with self._lock:
            if self._owner != "outside":
                return True           # the station drives: its own session stops it
            drv = self._driver if self._driver is not None else self._open()
            drv.stop()
            self._pending, self._watched = False, None
        self.events("info", text="control port: all-stop sent")
        return True

    def close(self) -> None:
        """Stop serving; all-stop if the server holds the rotator with a move pending; close
        the sockets and the driver."""
        self._stop_serving()
        with self._lock:
            try:
                if self._driver is not None and self._pending:
                    self._driver.stop()
                    self._pending = False
                    self.events("info", text="control port closed: all-stop sent")
            finally:
                self._drop_driver()
        for t in self._threads:
            if t is not threading.current_thread():
                t.join(timeout=5.0)
        self._threads = []

    def __enter__(self) -> RotctldServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # Ownership -------------------------------------------------------------------------------

    def hand_over(self) -> None:
        """Outside clients may drive; the driver opens on the next command that needs it."""
        with self._lock:
            self._owner = "outside"
        self.events("info", text="control port: outside clients may drive the rotator")
        self._publish()

    def take_back(self, reason: str) -> None:
        """The station takes the rotator: stop any outside move, close the driver (the
        station opens the same port), answer moves ``RPRT -9`` from now on."""
        with self._lock:
            try:
                if self._driver is not None and self._pending:
                    self._driver.stop()
            except TrackerError as e:
                self.events("error", text=f"control port: stop on take-back failed: {e}")
            finally:
                self._drop_driver()
                self._owner = "station"
        self.events("info", text=f"control port: the station took the rotator ({reason})")
        self._publish()

    # Serving ---------------------------------------------------------------------------------

    def _serve_client(self, rfile: Any, wfile: Any) -> None:
        self._count(+1)
        try:
            while True:
                raw = rfile.readline(MAX_LINE_BYTES + 1)
                if not raw.endswith(b"\n"):
                    self._unterminated(raw, wfile)
                    return
                line = raw.decode("ascii", "replace")
                if not line.strip():
                    continue
                sep, cmd, args = parse_line(line)
                if cmd in ("q", "Q"):
                    return
                wfile.write(self.answer(sep, cmd, args).encode("ascii"))
                wfile.flush()
        except (OSError, ValueError):
            pass    # the client went away; its move goes on, as with rotctld
        finally:
            self._count(-1)

    def _unterminated(self, raw: bytes, wfile: Any) -> None:
        """A read without its newline: the end of the stream, with a command cut short by a
        disconnect (never run: "P 100 3" may be the start of "P 100 35"), or a line longer
        than :data:`MAX_LINE_BYTES` (refused; the client is closed)."""
        if len(raw) > MAX_LINE_BYTES:
            self.events("refused", text=f"control port: a request line longer than "
                                        f"{MAX_LINE_BYTES} bytes; client closed")
            wfile.write(f"RPRT -{RIG_EINVAL}\n".encode("ascii"))
            wfile.flush()

    def _count(self, delta: int) -> None:
        with self._lock:
            self._clients += delta
        self._publish()

    def answer(self, sep: str | None, cmd: str, args: list[str]) -> str:
        """The reply text to one command (``sep``: the extended-response separator)."""
        reply = self._dispatch(cmd, args)
        if sep is None:
            out = reply.lines + ([f"RPRT {-reply.code}"] if reply.rprt or reply.code else [])
            return "".join(x + "\n" for x in out)
        name, _n, labels = COMMANDS.get(cmd, (cmd.lstrip("\\"), 0, ()))
        head = f"{name}:" + "".join(" " + a for a in args)
        body = [f"{lab}: {v}" for lab, v in zip(labels, reply.lines, strict=False)] \
            if labels else reply.lines
        return sep.join([head, *body, f"RPRT {-reply.code}"]) + "\n"

    def _dispatch(self, cmd: str, args: list[str]) -> Reply:
        handlers: dict[str, Callable[[list[str]], Reply]] = {
            "p": self._get_pos, "P": self._set_pos, "S": self._stop, "K": self._park,
            "_": self._get_info, "M": self._move, "\x8f": self._dump_state,
            "\x01": self._dump_caps}
        handler = handlers.get(cmd)
        if handler is None:
            return Reply([], RIG_ENIMPL)
        try:
            return handler(args)
        except Refused as e:
            if e.text:
                self.events("refused", text=f"control port: {e.text}")
            return Reply([], e.code)
        except RotatorIOError as e:
            return Reply([], self._io_failed(e))

    def _io_failed(self, e: RotatorIOError) -> int:
        """The controller failed: say so, drop the driver (the next command reopens it)."""
        self.events("error", text=f"control port: controller error: {e}")
        with self._lock:
            self._drop_driver()
        if isinstance(e, RotatorTimeout):
            return RIG_ETIMEOUT
        return RIG_EPROTO if isinstance(e, ProtocolError) else RIG_EIO

    # The driver ------------------------------------------------------------------------------

    def _held(self) -> RotatorDriver:
        """The driver, opened if needed; refuses while the station holds the rotator."""
        if self._owner != "outside" or self._closed.is_set():
            raise Refused(RIG_ERJCTED)
        return self._driver if self._driver is not None else self._open()

    def _open(self) -> RotatorDriver:
        drv = self.connect()
        # A client's move goes on after it disconnects; close() decides about stopping.
        drv.stop_on_exit = False  # type: ignore[attr-defined]
        self._driver = drv
        self._limits = EffectiveLimits.of(self.spec, self.station, drv.capabilities)
        return drv

    def _drop_driver(self) -> None:
        drv, self._driver, self._limits = self._driver, None, None
        self._watched, self._pending = None, False
        if drv is not None:
            try:
                drv.close()
            except (TrackerError, OSError):
                pass

    def _effective(self) -> EffectiveLimits:
        self._held()
        assert self._limits is not None
        return self._limits

    # Frames: the one place the server converts (bearings for the board) ----------------------

    def _bearing_of_wire(self, wire_az_deg: float, belief_m_deg: float | None = None) -> float:
        frame = self.spec.frame
        return float(frame.bearing_of(frame.nearest_mech_of_wire(wire_az_deg, belief_m_deg)))

    def _wire_of_bearing(self, bearing_deg: float) -> float:
        frame = self.spec.frame
        return float(frame.wire_of(float(frame.mech_of(bearing_deg))))

    def _mech_of_wire(self, wire_az_deg: float, belief_m_deg: float | None = None) -> float:
        return float(self.spec.frame.nearest_mech_of_wire(wire_az_deg, belief_m_deg))

    # Commands --------------------------------------------------------------------------------

    def _read(self) -> tuple[float, float | None]:
        """Read the position back (wire degrees) and post it to the board."""
        az, el = self._held().position()
        if self.board is not None:
            self.board.set_antenna(self._bearing_of_wire(az), el)
        return az, el

    def _get_pos(self, _args: list[str]) -> Reply:
        with self._lock:
            if self._owner == "outside":
                az, el = self._read()
            else:
                az, el = self._board_position()
        return Reply([f"{az:.2f}", f"{0.0 if el is None else el:.2f}"], rprt=False)

    def _board_position(self) -> tuple[float, float | None]:
        antenna = self.board.status()["antenna"] if self.board is not None else None
        if not antenna:
            raise Refused(RIG_ERJCTED)
        return self._wire_of_bearing(antenna["az_deg"]), antenna["el_deg"]

    def _set_pos(self, args: list[str]) -> Reply:
        az, el = (_degrees(a) for a in (args + [""] * 2)[:2])
        if az is None or el is None:
            raise Refused(RIG_EINVAL, f"set_pos {' '.join(args)!r}: give AZ EL in "
                                      f"degrees")
        with self._lock:
            self._guarded_goto(az, el, "set_pos")
        return Reply([])

    def _park(self, _args: list[str]) -> Reply:
        with self._lock:
            limits = self._effective()
            park_m, park_el = park_position(self.spec, self.station) if self.station \
                else (self.spec.park_az_deg, self.spec.park_el_deg)
            el = park_el if limits.has_elevation else 0.0
            self._guarded_goto(self.spec.frame.wire_of(park_m), el, "park")
        return Reply([])

    def _guarded_goto(self, az: float, el: float, what: str) -> None:
        """Check a move against the effective limits and the mask, send it, watch it."""
        drv = self._held()
        limits = self._effective()
        el_arg = el if limits.has_elevation else None
        try:
            limits.check_wire(az, el_arg)
        except LimitError as e:
            raise Refused(RIG_EINVAL, f"{what} refused, nothing sent: {e}") from None
        start = self._read() if drv.capabilities.has_position_query else None
        if start is not None and not self._path_clears_mask(start, az, el_arg):
            raise Refused(RIG_EINVAL, f"{what} az {az:g} el {el:g} refused, nothing sent: on "
                                      f"its way the antenna would point below the horizon "
                                      f"mask; move in smaller steps (raise the elevation "
                                      f"first)")
        drv.goto(az, el_arg)
        self._pending = True
        self._watched = None if start is None else self._watch(start, az, el_arg)

    def _path_clears_mask(self, start: tuple[float, float | None], az: float,
                          el: float | None) -> bool:
        """Both axes turning together from the read-back ``start`` keep the boresight on or
        above the mask (geometry's guard). From a start already below it (a low park) only
        the end counts, which the limits checked: the antenna must be able to leave."""
        if self.station is None or el is None or start[1] is None:
            return True
        m0 = self._mech_of_wire(start[0])
        if not bool(boresight_horizon_ok(self.spec, self.station, m0, start[1])):
            return True
        return move_clears_mask(self.spec, self.station, (m0, start[1]),
                                (self._mech_of_wire(az, m0), el))

    def _stop(self, _args: list[str]) -> Reply:
        with self._lock:
            self._held().stop()
            self._pending, self._watched = False, None
        return Reply([])

    def _move(self, _args: list[str]) -> Reply:
        if self._owner != "outside":
            raise Refused(RIG_ERJCTED)
        raise Refused(RIG_ENAVAIL, "move (M) refused: a continuous move cannot be checked "
                                   "against the limits and the horizon mask; use P AZ EL")

    def _get_info(self, _args: list[str]) -> Reply:
        return Reply([f"tracker control port: {self.spec.name}"], rprt=False)

    def _scale(self) -> tuple[float, float, float, float, bool]:
        """(min az, max az, min el, max el, has elevation) in wire degrees: the effective
        limits when the driver is open, else the spec's own scale."""
        with self._lock:
            limits = self._limits if self._limits is not None else \
                EffectiveLimits.of(self.spec, self.station)
        el = limits.el_range_deg or (0.0, 0.0)
        return 0.0, limits.wire_az_top_deg, el[0], el[1], limits.has_elevation

    def _dump_state(self, _args: list[str]) -> Reply:
        lo, hi, el_lo, el_hi, has_el = self._scale()
        return Reply([str(DUMP_STATE_VERSION), str(ROT_MODEL_NETROTCTL),
                      f"min_az={lo:f}", f"max_az={hi:f}", f"min_el={el_lo:f}",
                      f"max_el={el_hi:f}", "south_zero=0",
                      f"rot_type={'AzEl' if has_el else 'Az'}", "done"], rprt=False)

    def _dump_caps(self, _args: list[str]) -> Reply:
        lo, hi, el_lo, el_hi, _has_el = self._scale()
        return Reply([f"Caps dump for model:\t{ROT_MODEL_NETROTCTL}",
                      f"Model name:\t\ttracker control port ({self.spec.name})",
                      "Mfg name:\t\ttracker", f"Min Azimuth:\t\t{lo:.2f}",
                      f"Max Azimuth:\t\t{hi:.2f}", f"Min Elevation:\t\t{el_lo:.2f}",
                      f"Max Elevation:\t\t{el_hi:.2f}", "Can set Position:\tY",
                      "Can get Position:\tY", "Can Stop:\t\tY", "Can Park:\t\tY",
                      "Can Move:\t\tN", "Can get Info:\t\tY"])

    # The stall watch -------------------------------------------------------------------------

    def _watch(self, start: tuple[float, float | None], az: float, el: float | None
               ) -> _Watched:
        """Start watching a move from the read-back ``start`` to wire ``az``/``el`` with the
        live loop's stall bookkeeping (:class:`~tracker.stall.AxisWatch`)."""
        t = self.clock.monotonic()
        m0 = self._mech_of_wire(start[0])
        m1 = self._mech_of_wire(az, m0)
        motor = MotorModel(self.spec, az_deg=m0, el_deg=start[1], t_s=t)
        motor.command(m1, el, t)
        w = _Watched(az, el, m1)
        w.watches["az"] = AxisWatch()
        w.watches["az"].start(motor.az, t, m0)
        if motor.el is not None and el is not None and start[1] is not None:
            w.watches["el"] = AxisWatch()
            w.watches["el"].start(motor.el, t, start[1])
        return w

    def _watch_loop(self) -> None:
        while not self._closed.is_set():
            self.clock.sleep(self.poll_s)
            try:
                with self._lock:
                    if self._watched is not None and self._driver is not None \
                            and not self._closed.is_set():
                        self._check_watched(self._watched)
            except Refused:
                pass                    # the station took the rotator meanwhile
            except RotatorIOError as e:
                self._io_failed(e)

    def _check_watched(self, w: _Watched) -> None:
        """One read-back of a watched move: done, a re-send (a command lost on the line is
        not a stall), or a stall (all-stop and report)."""
        drv = self._driver
        assert drv is not None
        az, el = self._read()
        t = self.clock.monotonic()
        res = self.spec.resolution_deg
        quota = 1 + self.settings.stall_resends
        pos = {"az": self._mech_of_wire(az, w.belief_m_deg), "el": el}
        arrived, resend = True, False
        for name, watch in w.watches.items():
            p = pos[name]
            if p is None or watch.expect is None:
                continue
            if abs(p - watch.expect.target_deg) >= res - 1e-9:
                arrived = False
            stuck_s = watch.check(t, p, res, self.settings.stall_travel_deg)
            if stuck_s is not None and watch.sends_had_their_chance(t, quota):
                self._stalled(name, watch, t)
                return
            if watch.sends < quota and (stuck_s is not None or watch.motion_overdue(t, res)):
                resend = True
        if arrived:
            self._watched, self._pending = None, False
        elif resend:
            drv.goto(w.wire_az_deg, w.el_deg)
            for watch in w.watches.values():
                watch.resent(t)

    def _stalled(self, name: str, watch: AxisWatch, t: float) -> None:
        axis = "azimuth" if name == "az" else "elevation"
        error = stall_error(f"{axis} did not move: {watch.observation(t).text()}")
        self._watched = None
        try:
            assert self._driver is not None
            self._driver.stop()
            self._pending = False
        finally:
            text = f"control port: stall: {error}"
            self.events("stall", text=text)
            if self.board is not None:
                self.board.add_fault(text)

    # The board -------------------------------------------------------------------------------

    def _publish(self) -> None:
        if self.board is None:
            return
        info: Mapping[str, Any] = {"listen": self.listen, "owner": self._owner,
                                   "clients": self._clients}
        self.board.set_control_port(info)


def listen_address(text: str, default_port: int = 4533) -> tuple[str, int]:
    """``HOST:PORT`` (or ``HOST``, ``:PORT``, ``[v6]:PORT``) -> (host, port)."""
    from tracker.errors import ConfigError

    t = text.strip()
    host, sep, port = t.rpartition(":")
    if not sep or (t.count(":") > 1 and not t.startswith("[")):
        host, port = t, str(default_port)
    host = host.strip("[]") or "127.0.0.1"
    if not port.isdigit() or not 0 <= int(port) < 65536:
        raise ConfigError(f"listen address {text!r} is invalid; use HOST:PORT, e.g. "
                          f"127.0.0.1:4533")
    return host, int(port)


def is_loopback(host: str) -> bool:
    """True for an address only this machine can reach (127.x, ::1, localhost)."""
    import ipaddress

    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        try:
            return all(ipaddress.ip_address(info[4][0]).is_loopback
                       for info in socket.getaddrinfo(host, None))
        except (OSError, ValueError):
            return False
