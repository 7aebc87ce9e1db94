"""Emulated controllers reached in-process through ``emu://`` URLs, on virtual time.

``emu://PROFILE?rotator=G-5500&az=180&el=0&fault=jam=az@60&seed=1&autobaud=1`` names a
controller (any ``--protocol`` the registry, :mod:`tracker.controllers`, gives an emulator);
``fault`` may repeat and takes the
``tracker emulate --fault`` syntax. The port answers on write, synchronously: there is no pty,
no socket and no thread. A read that has to wait sleeps on the emulator's clock until the
first of: the read timeout, the next timed fault (disconnect, power cycle, jam, ...), the next
delayed reply, the next unsolicited output. Motor motion and table steps need no waking: the
controller evaluates them at exact clock times whenever it is asked.

So the waiting is as real as the clock: on a :class:`~tracker.clock.SystemClock` it is real
time (``tracker rotator --port emu://gs232b position`` talks to a simulated controller), on a
:class:`~tracker.clock.ManualClock` ``sleep`` advances the clock and a whole pass runs in CPU
time. The code under test must share that clock: pass it to :func:`tracker.transport.open_port`
(``clock=``), or make a :class:`Bench` on it and hand out ``bench.url``. Reopening the same URL
on the same clock reaches the same controller (the antenna stays where it was), like
reopening ``/dev/ttyUSB0``.
"""

from __future__ import annotations

import itertools
import threading
from urllib.parse import parse_qs, urlsplit

from serial.serialutil import SerialException

from tracker.clock import Clock, SystemClock
from tracker.emulator.faults import FaultInjector, install
from tracker.emulator.serve import feed_session, poll_session

SCHEME = "emu"
_MIN_WAIT_S = 1e-4              # a wait never shorter than this (floating-point progress)
_BENCHES: dict[str, Bench] = {}
_REG_LOCK = threading.Lock()
_names = itertools.count(1)
_QUERY_KEYS = ("rotator", "mains", "az", "el", "fault", "seed", "autobaud")


class Bench:
    """One emulated controller box, reachable at :attr:`url` while it is open.

    ``written`` records every chunk a client wrote as ``(clock.monotonic(), bytes)``, so a test
    can check what reached the wire and when (e.g. that ``S`` came last).
    """

    def __init__(self, controller, *, faults=(), seed: int = 0, name: str | None = None):
        self.controller = controller
        self.clock: Clock = controller.clock
        if faults:
            install(controller, faults, seed)
        self.name = name or f"bench-{next(_names)}"
        self.url = f"{SCHEME}://{self.name}"
        self.plugged = True
        self.written: list[tuple[float, bytes]] = []
        self.links: list[_Link] = []
        self.lock = threading.RLock()
        with _REG_LOCK:
            _BENCHES[self.name] = self

    # Faults (the injector calls these by name, like a server's) ----------------------------

    @property
    def injector(self) -> FaultInjector | None:
        """The controller's fault injector (installed here or later with ``install``)."""
        return self.controller.faults.injector

    def fault_disconnect(self) -> None:
        """The device goes away: open ports fail on their next use, opens fail until
        :meth:`fault_reconnect`."""
        with self.lock:
            self.plugged = False
            for link in self.links:
                link.lost = True
                if self.injector is not None:
                    self.injector.forget(link.session)
            self.links.clear()

    def fault_reconnect(self) -> None:
        with self.lock:
            self.plugged = True

    unplug = fault_disconnect
    replug = fault_reconnect

    def drop_connections(self) -> None:
        """Every open port is cut off; the device stays (a client may reopen at once)."""
        self.fault_disconnect()
        self.fault_reconnect()

    def tick(self) -> None:
        """Fire the timed faults due now."""
        if self.injector is not None:
            self.injector.tick(self)

    def next_due_in_s(self) -> float | None:
        return self.injector.next_due_in_s() if self.injector is not None else None

    # Connections ---------------------------------------------------------------------------

    def open(self) -> _Link:
        with self.lock:
            self.tick()
            if not self.plugged:
                raise LookupError(f"{self.url}: no such device (unplugged)")
            link = _Link(self)
            self.links.append(link)
            return link

    def bytes_written(self) -> bytes:
        return b"".join(chunk for _t, chunk in self.written)

    @property
    def connections(self) -> int:
        return len(self.links)

    def close(self) -> None:
        """Forget this bench: its URL no longer opens."""
        with _REG_LOCK:
            if _BENCHES.get(self.name) is self:
                del _BENCHES[self.name]

    def __enter__(self) -> Bench:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class _Link:
    """One open ``emu://`` port: a session on the bench's controller and its input buffer."""

    def __init__(self, bench: Bench):
        self.bench = bench
        self.session = bench.controller.open_session()
        self.rx = bytearray()
        self.lost = False
        self.closed = False

    def _pump(self) -> None:
        """Fire due faults and take in whatever output is due now."""
        b = self.bench
        b.tick()
        if self.lost:
            raise SerialException(f"{b.url}: device disconnected")
        self.rx += poll_session(b.controller, self.session)

    def _next_due_in_s(self) -> float | None:
        dues = [self.bench.next_due_in_s()]
        nxt = getattr(self.session, "next_output_in_s", None)
        if nxt is not None:
            dues.append(nxt())
        dues = [d for d in dues if d is not None]
        return min(dues) if dues else None

    def write(self, data: bytes) -> int:
        b = self.bench
        with b.lock:
            self._pump()
            b.written.append((b.clock.monotonic(), data))
            self.rx += feed_session(b.controller, self.session, data)
        return len(data)

    def in_waiting(self) -> int:
        with self.bench.lock:
            self._pump()
            return len(self.rx)

    def reset_input(self) -> None:
        with self.bench.lock:
            self._pump()
            self.rx.clear()

    def read(self, size: int, timeout_s: float | None) -> bytes:
        """Up to ``size`` bytes; waits on the bench's clock for at most ``timeout_s``."""
        b = self.bench
        clock = b.clock
        deadline = None if timeout_s is None else clock.monotonic() + timeout_s
        while True:
            with b.lock:
                self._pump()
                if len(self.rx) >= size or timeout_s == 0:
                    break
                now = clock.monotonic()
                if deadline is not None and now >= deadline:
                    break
                due = self._next_due_in_s()
            waits = [w for w in (due, None if deadline is None else deadline - now)
                     if w is not None]
            if not waits:
                break           # nothing can ever arrive: do not block for ever
            clock.sleep(max(min(waits), _MIN_WAIT_S))
        with b.lock:
            out = bytes(self.rx[:size])
            del self.rx[:size]
        return out

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        b = self.bench
        with b.lock:
            if self in b.links:
                b.links.remove(self)
                if b.injector is not None:
                    b.injector.forget(self.session)


def make_controller(protocol: str, clock: Clock, rotator: str | None = None, mains: int = 60,
                    az_deg: float | None = None, el_deg: float | None = None,
                    autobaud: bool = False):
    """The emulator for ``protocol`` on ``clock`` (``rotator``: a preset name; None: the
    protocol's default rotator). ``el_deg`` applies to a controller with elevation,
    ``autobaud`` to one that takes the GS-232 switches; the others ignore them."""
    from tracker.controllers import find
    from tracker.emulator.factory import make_emulator
    from tracker.emulator.gs232_controller import EmulatorOptions
    from tracker.mount import preset

    entry = find(protocol)
    default = entry.default_rotator if entry is not None else None
    spec = preset(rotator or default, mains) if (rotator or default) else None
    kw: dict = {"az_deg": az_deg}
    if entry is not None and entry.has_elevation:
        kw["el_deg"] = el_deg
    if entry is not None and entry.gs232_switches:
        kw["options"] = EmulatorOptions(autobaud=autobaud)
    return make_emulator(protocol, clock, spec, **kw)


def _bench_from_url(url: str, clock: Clock) -> Bench:
    parts = urlsplit(url)
    query = parse_qs(parts.query, keep_blank_values=True)
    unknown = sorted(set(query) - set(_QUERY_KEYS))
    if unknown:
        raise ValueError(f"unknown option {unknown[0]!r} in {url!r}; known: "
                         f"{', '.join(_QUERY_KEYS)}")

    def one(key: str, cast=str, default=None):
        vals = query.get(key)
        return default if not vals else cast(vals[-1])

    ctrl = make_controller(parts.netloc, clock, rotator=one("rotator"),
                           mains=one("mains", int, 60), az_deg=one("az", float),
                           el_deg=one("el", float),
                           autobaud=one("autobaud", str, "0") not in ("0", "", "no", "false"))
    return Bench(ctrl, faults=query.get("fault", []), seed=one("seed", int, 0),
                 name=f"{url}#{id(clock)}")


def attach(url: str, clock: Clock | None = None) -> _Link:
    """Open ``url``: a :class:`Bench` by name, or the controller the URL describes (made on
    first use on ``clock``, default real time, and found again by the same URL and clock)."""
    parts = urlsplit(url)
    if parts.scheme.lower() != SCHEME or not parts.netloc:
        raise ValueError(f"expected emu://PROFILE[?rotator=NAME&...] or emu://BENCH, got "
                         f"{url!r}")
    with _REG_LOCK:
        bench = _BENCHES.get(parts.netloc)
    if bench is not None:
        if clock is not None and clock is not bench.clock:
            raise ValueError(f"{url} runs on its own clock; pass that clock (bench.clock) "
                             f"to the code under test, or none")
        return bench.open()
    clock = clock or SystemClock()
    with _REG_LOCK:
        bench = _BENCHES.get(f"{url}#{id(clock)}")
    if bench is None or bench.clock is not clock:
        bench = _bench_from_url(url, clock)
    return bench.open()


def clock_of(url: str) -> Clock | None:
    """The clock of the :class:`Bench` ``url`` names (None: not a bench, e.g. a profile)."""
    with _REG_LOCK:
        bench = _BENCHES.get(urlsplit(url).netloc)
    return bench.clock if bench is not None else None
