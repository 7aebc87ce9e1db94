"""Scripted, reproducible fault injection for the emulated controllers.

A fault is written as ``NAME[=VALUE][@START_S]`` (the ``tracker emulate --fault`` syntax):

=====================  ====================================================================
``drop=0.01``          drop each byte with probability 0.01 (``:in`` / ``:out`` for one
                       direction only; default both ways, like line noise);
                       ``drop=0.01@100+30``: only from t=100 s for 30 s (any rate or delay)
``garble=0.01``        replace each byte by a random byte with that probability
``duplicate=0.01``     send each byte twice with that probability
``delay=0.2``          hold every reply for 0.2 s before it is sent
``silent=30@120``      from t=120 s, act on commands but answer nothing for 30 s
``deaf=30@120``        from t=120 s, ignore all input for 30 s
``powercycle@300``     interface off and on at t=300 s (``powercycle=2@300``: off for 2 s):
                       tables lost, motors stopped, autobaud again
``jam=az@60``          the azimuth motor stalls at t=60 s (``jam=el:30@60``: for 30 s)
``drift=0.5%``         the controller's step clock runs 0.5 % slow (negative: fast);
                       also ``ppm``; ``drift=0.5%@600``: from t=600 s on
``wrongside``          read-back in 0-359 although the rotator is in 450 mode: the wrong
                       side of the overlap (``wrongside@600``: from t=600 s on)
``disconnect=5@200``   close the pty or every TCP connection at t=200 s and reopen after 5 s
=====================  ====================================================================

Times are seconds of the emulator's injected Clock after the injector is installed, so a
SimClock running 100x replays a 24 h schedule in minutes and a ManualClock makes tests exact.
All randomness comes from one ``random.Random(seed)``: the same seed and the same traffic give
the same faults.
"""

from __future__ import annotations

import random
import re
import threading
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Literal

from tracker.errors import ConfigError

RATE_KINDS = ("drop", "garble", "duplicate")
WINDOW_KINDS = ("silent", "deaf", "disconnect")
ALL_KINDS = (*RATE_KINDS, *WINDOW_KINDS, "delay", "powercycle", "jam", "drift", "wrongside")
DEFAULT_POWER_OFF_S = 1.0

_SPEC_RE = re.compile(r"^(?P<name>[a-z]+)(?:=(?P<value>[^@]*))?(?:@(?P<start>[^@]+))?$")

EXAMPLES = ("drop=0.01", "garble=0.01:out", "drop=0.05@100+30", "duplicate=0.01", "delay=0.2",
            "silent=30@120", "deaf=10@60", "powercycle@300", "jam=az@60", "jam=el:30@60",
            "drift=0.5%", "wrongside", "disconnect=5@200")


@dataclass(frozen=True)
class FaultSpec:
    """One parsed fault. ``value`` is a probability (rate kinds), seconds (delay, windows,
    powercycle off time, jam duration: None = for ever) or a fraction (drift)."""

    kind: str
    value: float | None = None
    start_s: float = 0.0
    axis: Literal["az", "el"] = "az"
    direction: Literal["in", "out", "both"] = "both"
    text: str = ""
    for_s: float | None = None        # rate / delay faults: active this long (None: for ever)

    def active_at(self, t_s: float) -> bool:
        return t_s >= self.start_s and (self.for_s is None or t_s < self.start_s + self.for_s)

    @property
    def end_s(self) -> float | None:
        if self.kind in (*WINDOW_KINDS, "jam") and self.value is not None:
            return self.start_s + self.value
        return None


def _bad(text: str, why: str) -> ConfigError:
    return ConfigError(f"fault {text!r}: {why}. Write NAME[=VALUE][@START_S], e.g. "
                       + ", ".join(EXAMPLES))


def _number(text: str, s: str, what: str, lo: float = 0.0, hi: float = float("inf")) -> float:
    try:
        v = float(s)
    except ValueError:
        raise _bad(text, f"{what} {s!r} is not a number") from None
    if not (lo <= v <= hi) or v != v:
        raise _bad(text, f"{what} {s!r} must be in {lo:g}..{hi:g}")
    return v


# One guard per part of the --fault syntax, each with its own message.
def parse_fault(text: str) -> FaultSpec:  # noqa: C901
    """Parse one ``--fault`` argument; raises :class:`ConfigError` naming what is wrong."""
    raw = str(text).strip()
    m = _SPEC_RE.match(raw.lower().replace(" ", ""))
    if not m:
        raise _bad(raw, "cannot read it")
    name, value, start = m.group("name"), m.group("value"), m.group("start")
    if name not in ALL_KINDS:
        raise _bad(raw, f"unknown fault {name!r}; known: {', '.join(ALL_KINDS)}")
    for_s = None
    if start is not None and "+" in start:
        if name not in (*RATE_KINDS, "delay"):
            raise _bad(raw, f"@START+DURATION is for rate and delay faults; {name} takes its "
                            f"duration as the value")
        start, dur = start.split("+", 1)
        for_s = _number(raw, dur, "duration")
    start_s = 0.0 if start is None else _number(raw, start, "start time")
    if name in RATE_KINDS:
        if not value:
            raise _bad(raw, f"{name} needs a probability, e.g. {name}=0.01")
        prob, _, direction = value.partition(":")
        direction = direction or "both"
        if direction not in ("in", "out", "both"):
            raise _bad(raw, f"direction {direction!r} must be in, out or both")
        return FaultSpec(name, _number(raw, prob, "probability", 0.0, 1.0), start_s,
                         direction=direction, text=raw, for_s=for_s)  # type: ignore[arg-type]
    if name == "delay":
        if not value:
            raise _bad(raw, "delay needs seconds, e.g. delay=0.2")
        return FaultSpec(name, _number(raw, value, "delay", 0.0, 3600.0), start_s, text=raw,
                         for_s=for_s)
    if name in WINDOW_KINDS:
        if not value:
            raise _bad(raw, f"{name} needs a duration, e.g. {name}=30@120")
        return FaultSpec(name, _number(raw, value, "duration", 0.0), start_s, text=raw)
    if name == "powercycle":
        off_s = DEFAULT_POWER_OFF_S if not value else _number(raw, value, "off time", 0.0, 600)
        return FaultSpec(name, off_s, start_s, text=raw)
    if name == "jam":
        axis, _, dur = (value or "az").partition(":")
        if axis not in ("az", "el"):
            raise _bad(raw, f"axis {axis!r} must be az or el")
        return FaultSpec(name, _number(raw, dur, "duration") if dur else None, start_s,
                         axis=axis, text=raw)  # type: ignore[arg-type]
    if name == "drift":
        if not value:
            raise _bad(raw, "drift needs a size, e.g. drift=0.5% or drift=-200ppm")
        if value.endswith("%"):
            frac = _number(raw, value[:-1], "drift", -50.0, 50.0) / 100.0
        elif value.endswith("ppm"):
            frac = _number(raw, value[:-3], "drift", -5e5, 5e5) / 1e6
        else:
            frac = _number(raw, value, "drift", -0.5, 0.5)
        return FaultSpec(name, frac, start_s, text=raw)
    if value:
        raise _bad(raw, "wrongside takes no value")
    return FaultSpec(name, None, start_s, text=raw)


@dataclass
class FaultPlan:
    """A list of faults and the RNG seed that makes them reproducible."""

    specs: list[FaultSpec] = field(default_factory=list)
    seed: int = 0

    @classmethod
    def parse(cls, texts: Iterable[str], seed: int = 0) -> FaultPlan:
        return cls([parse_fault(t) for t in texts], int(seed))

    def of(self, kind: str) -> list[FaultSpec]:
        return [s for s in self.specs if s.kind == kind]

    @property
    def needs_reopen(self) -> bool:
        return bool(self.of("disconnect"))


@dataclass
class _Event:
    t_s: float
    name: str
    spec: FaultSpec


class FaultInjector:
    """Applies a :class:`FaultPlan` to one controller (and, through :meth:`tick`, its server).

    The controller's sessions call :meth:`on_input` / :meth:`on_output` / :meth:`release`;
    the server loop calls :meth:`tick` so timed faults fire even with no client attached.
    ``stats`` counts what was injected (bytes dropped, events fired, ...).
    """

    def __init__(self, controller: Any, plan: FaultPlan):
        self.controller = controller
        self.plan = plan
        self.clock = controller.clock
        self.rng = random.Random(plan.seed)
        self.stats: Counter[str] = Counter()
        self.events_log: list[tuple[float, str]] = []
        self._lock = threading.RLock()
        self.t0 = self.clock.monotonic()
        self._queues: dict[int, list[tuple[float, bytes]]] = {}
        events: list[_Event] = []
        for s in plan.specs:
            if s.kind in ("silent", "deaf", "disconnect", "powercycle", "jam"):
                events.append(_Event(s.start_s, "start", s))
                end = s.start_s + s.value if s.value is not None else None
                if end is not None:
                    events.append(_Event(end, "end", s))
            elif s.kind in ("drift", "wrongside") and s.start_s > 0:
                events.append(_Event(s.start_s, "start", s))   # from then on, for good
        self._events = sorted(events, key=lambda e: e.t_s)
        self._active: Counter[str] = Counter()
        self._pending_server_actions: list[str] = []
        faults = controller.faults
        faults.injector = self
        self._drift_now = 0.0
        faults.wrongside = any(s.start_s <= 0 for s in plan.of("wrongside"))
        for s in plan.of("drift"):
            if s.start_s <= 0:
                self._drift_now += s.value or 0.0
        faults.step_clock_scale = 1.0 + self._drift_now

    # Time ----------------------------------------------------------------------------------

    def elapsed_s(self) -> float:
        return self.clock.monotonic() - self.t0

    def tick(self, server: Any = None) -> None:
        """Fire every timed event that is due. ``server`` (if given) performs disconnects."""
        with self._lock:
            now = self.elapsed_s()
            while self._events and self._events[0].t_s <= now:
                ev = self._events.pop(0)
                self._fire(ev)
            if server is not None and self._pending_server_actions:
                actions, self._pending_server_actions = self._pending_server_actions, []
                for action in actions:
                    getattr(server, action)()

    def _fire(self, ev: _Event) -> None:
        s, ctrl = ev.spec, self.controller
        self.events_log.append((ev.t_s, f"{s.kind} {ev.name}"))
        if ev.name == "start":
            self.stats[f"{s.kind}_events"] += 1
        if s.kind in ("silent", "deaf"):
            self._active[s.kind] += 1 if ev.name == "start" else -1
        elif s.kind == "powercycle":
            if ev.name == "start":
                if hasattr(ctrl, "power_cycle"):
                    ctrl.power_cycle(reset_sessions=True)
                else:   # byte controllers: at least the motor stops when power goes
                    ctrl.motor.stop(ctrl.clock.monotonic())
                self._active["off"] += 1
                self._queues.clear()
            else:
                self._active["off"] -= 1
        elif s.kind == "jam":
            has_axis = s.axis == "az" or getattr(ctrl.motor, "el", None) is not None
            if not has_axis:                       # az-only rotator: nothing to jam
                self.stats["not_applicable"] += 1 if ev.name == "start" else 0
            elif hasattr(ctrl, "power_cycle"):     # GS-232: jam(axis, jammed)
                ctrl.jam(s.axis, ev.name == "start")
            else:                                  # byte controllers: azimuth only
                ctrl.jam(ev.name == "start")
        elif s.kind == "disconnect":
            self._pending_server_actions.append(
                "fault_disconnect" if ev.name == "start" else "fault_reconnect")
        elif s.kind == "drift":
            self._drift_now += s.value or 0.0
            ctrl.faults.step_clock_scale = 1.0 + self._drift_now
        elif s.kind == "wrongside":
            ctrl.faults.wrongside = True

    def active(self, kind: str) -> bool:
        return self._active[kind] > 0

    # Bytes ---------------------------------------------------------------------------------

    def _rate(self, kind: str, direction: str, now: float) -> float:
        p = 0.0
        for s in self.plan.of(kind):
            if s.direction in (direction, "both") and s.active_at(now):
                p = max(p, s.value or 0.0)
        return p

    def _mangle(self, data: bytes, direction: str) -> bytes:
        now = self.elapsed_s()
        drop = self._rate("drop", direction, now)
        garble = self._rate("garble", direction, now)
        dup = self._rate("duplicate", direction, now)
        if not (drop or garble or dup) or not data:
            return data
        rnd = self.rng.random
        out = bytearray()
        for b in data:
            if drop and rnd() < drop:
                self.stats["bytes_dropped"] += 1
                continue
            if garble and rnd() < garble:
                b = self.rng.randrange(256)
                self.stats["bytes_garbled"] += 1
            out.append(b)
            if dup and rnd() < dup:
                out.append(b)
                self.stats["bytes_duplicated"] += 1
        return bytes(out)

    def accepts_input(self) -> bool:
        """False while the unit is deaf or switched off (input is lost, not buffered)."""
        self.tick()
        return not (self.active("deaf") or self.active("off"))

    def on_input(self, data: bytes) -> bytes:
        with self._lock:
            if not self.accepts_input():
                self.stats["bytes_ignored"] += len(data)
                return b""
            return self._mangle(data, "in")

    def on_output(self, session: object, reply: bytes) -> bytes:
        """Mangle ``reply``; with a delay it is queued and comes out of :meth:`release`."""
        with self._lock:
            self.tick()
            if self.active("silent") or self.active("off"):
                self.stats["replies_suppressed"] += 1
                return b""
            reply = self._mangle(reply, "out")
            delays = [s.value or 0.0 for s in self.plan.of("delay")
                      if s.active_at(self.elapsed_s())]
            if delays and max(delays) > 0 and reply:
                q = self._queues.setdefault(id(session), [])
                q.append((self.elapsed_s() + max(delays), reply))
                self.stats["replies_delayed"] += 1
                return b""
            return reply

    def release(self, session: object) -> bytes:
        """Delayed reply bytes that are due now for ``session``."""
        with self._lock:
            q = self._queues.get(id(session))
            if not q:
                return b""
            now = self.elapsed_s()
            out = bytearray()
            while q and q[0][0] <= now:
                out += q.pop(0)[1]
            if not q:
                del self._queues[id(session)]
            return bytes(out)

    def next_release_in_s(self) -> float | None:
        """Emulator seconds until the next delayed reply is due (None: nothing queued)."""
        with self._lock:
            heads = [q[0][0] for q in self._queues.values() if q]
            return (min(heads) - self.elapsed_s()) if heads else None

    def next_due_in_s(self) -> float | None:
        """Emulator seconds until the next timed event or delayed reply (None: none left);
        a virtual port waits exactly this long instead of polling."""
        with self._lock:
            nxt = [self._events[0].t_s - self.elapsed_s()] if self._events else []
            release = self.next_release_in_s()
            if release is not None:
                nxt.append(release)
            return max(0.0, min(nxt)) if nxt else None

    def forget(self, session: object) -> None:
        with self._lock:
            self._queues.pop(id(session), None)

    def summary(self) -> str:
        parts = [f"{k} {v}" for k, v in sorted(self.stats.items())]
        return "faults: " + (", ".join(parts) if parts else "none injected yet")


def install(controller: Any, specs: Iterable[str] | FaultPlan, seed: int = 0) -> FaultInjector:
    """Parse ``specs`` (or take a ready plan) and attach an injector to ``controller``."""
    plan = specs if isinstance(specs, FaultPlan) else FaultPlan.parse(specs, seed)
    return FaultInjector(controller, plan)
