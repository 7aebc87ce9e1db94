"""The real-I/O tier's benches: an emulated controller served on a real pty or TCP socket,
and ``tracker emulate`` as a real subprocess. The fixtures that build them are in
``conftest.py``."""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from datetime import datetime

import pytest
from _gs232_helpers import SPEED, T0, WAIT_S, wait_until

from tracker.clock import SimClock
from tracker.controllers import in_family
from tracker.emulator import serve_pty, serve_tcp
from tracker.emulator.factory import make_emulator
from tracker.protocols import open_driver

GS232_PROFILES = in_family("gs232")


def make_controller(protocol: str, clock, **kw):
    """The project's emulator for ``protocol``, as the registry makes it (``kw``: the
    controller's own arguments, ``spec`` among them)."""
    return make_emulator(protocol, clock, kw.pop("spec", None), **kw)


class EmulatedRig:
    """One emulated controller served on a real pty or TCP socket, on a fast SimClock."""

    def __init__(self, protocol: str, transport: str, speed: float = SPEED, **ctrl_kw):
        self.protocol, self.transport = protocol, transport
        self.clock = SimClock(datetime.fromisoformat(T0), speed=speed)
        self.ctrl = make_controller(protocol, self.clock, **ctrl_kw)
        self.server = serve_tcp(self.ctrl) if transport == "tcp" else serve_pty(self.ctrl)
        self.url = self.server.url

    def driver(self, protocol: str | None = None, **kw):
        kw.setdefault("timeout_s", 0.5)
        return open_driver(self.url, protocol or self.protocol, **kw)

    def lines(self) -> list[bytes]:
        """Every command line the controller received, in order."""
        return [line for _t, line, _r in self.ctrl.log]

    def seen(self, line: bytes) -> bool:
        """Whether the controller received ``line`` (waits: set commands get no reply)."""
        return wait_until(lambda: line in self.lines(), WAIT_S)

    def tail_is(self, *lines: bytes) -> bool:
        return wait_until(lambda: self.lines()[-len(lines):] == list(lines), WAIT_S)

    def close(self) -> None:
        self.server.close()

    def assert_released(self) -> None:
        """Leak check: the server thread ended and its descriptors are closed."""
        assert self.server.closed and not self.server.thread.is_alive()
        assert self.server.connections == 0
        for fd in getattr(self.server, "_fds", ()):
            with pytest.raises(OSError):
                os.fstat(fd)


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def default_signals(then=None):
    """A ``preexec_fn``: the child takes the stop signals as a terminal would deliver them.

    The suite may itself run with some ignored (a background job of a non-interactive shell
    ignores SIGINT, ``nohup`` SIGHUP), and a child inherits that; the tests that send a
    signal are about a normal process. ``then`` runs after, for a test that wants one
    ignored on purpose."""
    def preexec() -> None:
        for sig in STOP_SIGNALS:
            signal.signal(sig, signal.SIG_DFL)
        if then is not None:
            then()
    return preexec


class EmulateProcess:
    """``tracker emulate ARGS`` as a real subprocess: ``url`` is the port it printed.

    :meth:`stop` ends it with SIGTERM, never SIGINT: a process started in the background of a
    non-interactive shell inherits SIGINT as ignored, and so would this child.
    """

    def __init__(self, *args: str, url_now: bool = True, **popen_kw):
        popen_kw["preexec_fn"] = default_signals(popen_kw.get("preexec_fn"))
        self.proc = subprocess.Popen([sys.executable, "-m", "tracker", "emulate", *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, **popen_kw)
        self.url = self.read_url() if url_now else ""
        self.returncode: int | None = None

    def read_url(self) -> str:
        """The first line it prints: its port (blocks until it is serving)."""
        self.url = self.proc.stdout.readline().strip()
        return self.url

    def readline(self) -> str:
        return self.proc.stdout.readline()

    def stop(self, sig: int = signal.SIGTERM) -> tuple[int, str, str]:
        """Signal it, wait for it to end; returns (exit code, rest of stdout, stderr)."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            self.proc.wait(timeout=WAIT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        # not communicate(): it would bypass what readline() already buffered
        out, err = self.proc.stdout.read(), self.proc.stderr.read()
        self.proc.stdout.close()
        self.proc.stderr.close()
        self.returncode = self.proc.returncode
        return self.proc.returncode, out, err


class ServeRotctldProcess:
    """``tracker serve-rotctld ARGS`` as a real subprocess listening on a free 127.0.0.1 port
    (any ``--listen`` in ARGS is replaced): :attr:`where` is its ``HOST:PORT``."""

    def __init__(self, *args: str):
        if "--listen" in args:
            i = args.index("--listen")
            args = args[:i] + args[i + 2:]
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tracker", "serve-rotctld", "--listen", "127.0.0.1:0",
             *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            preexec_fn=default_signals())
        self.where = ""
        self.head: list[str] = []      # the lines up to the address line
        for _ in range(5):     # a banner may come first; the address line names the port
            line = self.proc.stdout.readline()
            self.head.append(line)
            m = re.search(r"control port on (127\.0\.0\.1:\d+)", line)
            if m:
                self.where = m[1]
                return
        self.proc.kill()
        raise AssertionError(f"serve-rotctld printed no address: {self.proc.communicate()}")

    def stop(self) -> tuple[int, str, str]:
        """SIGTERM, then (exit code, the rest of stdout, stderr)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            out, err = self.proc.communicate(timeout=WAIT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
        return self.proc.returncode, out, err


ROTCTLD = shutil.which("rotctld")
ROTCTL = shutil.which("rotctl")


def require_rotctl() -> None:
    """At module level: skip the module without Hamlib's rotctl, except in CI, where
    ``.ci/run`` installs it and a missing one is a failure, not a skip."""
    if ROTCTL is not None:
        return
    if os.environ.get("CI", "").lower() == "true":
        raise RuntimeError("rotctl not found but CI=true: install Debian's libhamlib-utils")
    pytest.skip("Hamlib rotctl not installed (apt install libhamlib-utils)",
                allow_module_level=True)


def rotctl(model: str, url: str, *cmds: str, ok: bool = True) -> subprocess.CompletedProcess:
    """``rotctl -m MODEL -r URL CMDS...``; with ``ok``, it must succeed."""
    r = subprocess.run([ROTCTL, "-m", model, "-r", url, *cmds], capture_output=True,
                       text=True, timeout=30)
    if ok:
        assert r.returncode == 0, f"rotctl -m {model} {cmds}: {r.stdout} {r.stderr[-500:]}"
    return r


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_rotctld(*args: str) -> tuple[subprocess.Popen, int]:
    """Hamlib ``rotctld ARGS`` on a free 127.0.0.1 port; returns once it accepts."""
    for _attempt in range(3):
        port = free_port()
        proc = subprocess.Popen([ROTCTLD, *args, "-T", "127.0.0.1", "-t", str(port)],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        end = time.monotonic() + WAIT_S
        while time.monotonic() < end and proc.poll() is None:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                return proc, port
            except OSError:
                time.sleep(0.02)
        proc.kill()
        proc.wait()
    raise RuntimeError(f"rotctld {args} did not start listening")


def stop_process(proc: subprocess.Popen) -> None:
    """SIGTERM, then wait (SIGKILL only if it will not end)."""
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.wait(WAIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
